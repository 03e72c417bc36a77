// What the hostile-file tests share: a scene of a camera and the rest, a test folder with
// sparse files and FIFOs in it, and a PNG that claims any size. The library's tests
// (input_limits_test.cpp) and the command line's (hostile_cli_test.cpp) use them.
#pragma once

#include "temp_dir.hpp"

#include <gtest/gtest.h>

#include <sys/stat.h>

#include <cstdint>
#include <filesystem>
#include <string>

namespace nephele::test {

inline const std::string kCamera = R"("camera": {"position": [0, 0, 0], "look_at": [0, 1, 0]})";
inline std::string sceneWith(const std::string& rest) { return R"({"cloudscene": 1, )" + kCamera + ", " + rest + "}"; }

class HostileFileTest : public ::testing::Test {
protected:
    // The test's folder, removed at its end (with the process id: it had none, and other
    // checkouts on the machine run the same tests at the same time).
    test::TempDir tmp_{"nephele_hostile_"};
    const std::filesystem::path& dir_ = tmp_.dir();
    std::string path(const std::string& name) const { return tmp_.path(name); }
    std::string write(const std::string& name, const std::string& bytes) const { return tmp_.write(name, bytes); }
    // A file of `bytes` zero bytes that takes no disk space (the size check comes first).
    std::string sparse(const std::string& name, std::uint64_t bytes) const {
        write(name, "");
        std::filesystem::resize_file(path(name), bytes);
        return path(name);
    }
    std::string fifo(const std::string& name) const {
        EXPECT_EQ(::mkfifo(path(name).c_str(), 0600), 0);
        return path(name);
    }
};

// A PNG whose IHDR claims w x h, with an IDAT of a few bytes and valid CRCs.
inline std::string claimingPng(std::uint32_t w, std::uint32_t h) {
    auto crc32 = [](const std::string& s) {
        std::uint32_t c = 0xffffffffu;
        for (unsigned char b : s) {
            c ^= b;
            for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
        }
        return c ^ 0xffffffffu;
    };
    auto be32 = [](std::uint32_t v) { return std::string{char(v >> 24), char(v >> 16), char(v >> 8), char(v)}; };
    auto chunk = [&](const std::string& type, const std::string& data) {
        return be32(std::uint32_t(data.size())) + type + data + be32(crc32(type + data));
    };
    const std::string ihdr = be32(w) + be32(h) + std::string{8, 6, 0, 0, 0};
    const std::string idat("\x78\x9c\x63\x00\x00\x00\x01\x00\x01", 9);  // zlib of one zero byte
    return "\x89PNG\r\n\x1a\n" + chunk("IHDR", ihdr) + chunk("IDAT", idat) + chunk("IEND", "");
}

}  // namespace nephele::test
