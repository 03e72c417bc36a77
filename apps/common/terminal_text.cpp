#include "terminal_text.hpp"

#include <cstdio>
#include <streambuf>

namespace nephele::cli {

namespace {

// The length of the UTF-8 sequence that starts at text[i] and its code point, or 0 if the
// bytes there are not a (complete, shortest-form) UTF-8 sequence.
std::size_t utf8At(std::string_view text, std::size_t i, char32_t* cp) {
    const auto b = [&](std::size_t k) { return static_cast<unsigned char>(text[i + k]); };
    const unsigned char c = b(0);
    const std::size_t n = c < 0x80 ? 1 : (c & 0xe0) == 0xc0 ? 2 : (c & 0xf0) == 0xe0 ? 3 : (c & 0xf8) == 0xf0 ? 4 : 0;
    if (n == 0 || i + n > text.size()) return 0;
    char32_t v = n == 1 ? c : n == 2 ? c & 0x1f : n == 3 ? c & 0x0f : c & 0x07;
    for (std::size_t k = 1; k < n; ++k) {
        if ((b(k) & 0xc0) != 0x80) return 0;
        v = (v << 6) | (b(k) & 0x3f);
    }
    static constexpr char32_t kSmallest[] = {0, 0, 0x80, 0x800, 0x10000};
    if (v < kSmallest[n] || v > 0x10ffff || (v >= 0xd800 && v <= 0xdfff)) return 0;
    *cp = v;
    return n;
}

bool mustEscape(char32_t c) {
    if (c == '\n' || c == '\t') return false;
    return c < 0x20 || (c >= 0x7f && c <= 0x9f)  // C0, DEL, C1
           || c == 0x061c                        // ARABIC LETTER MARK
           || (c >= 0x200b && c <= 0x200f)       // zero-width spaces and joiners, LRM, RLM
           || (c >= 0x2028 && c <= 0x202e)       // line and paragraph separators, embeddings, overrides
           || (c >= 0x2060 && c <= 0x2069)       // word joiner, invisible operators, isolates
           || c == 0xfeff;                       // zero-width no-break space
}

class EscapingBuf : public std::streambuf {
public:
    explicit EscapingBuf(std::streambuf* out) : out_(out) {}
    std::streambuf* target() const { return out_; }

protected:
    int_type overflow(int_type c) override {
        if (traits_type::eq_int_type(c, traits_type::eof())) return traits_type::not_eof(c);
        line_ += traits_type::to_char_type(c);
        if (line_.back() == '\n') emit(line_.size());
        return c;
    }
    std::streamsize xsputn(const char* s, std::streamsize n) override {
        line_.append(s, std::size_t(n));
        if (const std::size_t nl = line_.rfind('\n'); nl != std::string::npos) emit(nl + 1);
        return n;
    }
    int sync() override {
        // All but an incomplete UTF-8 sequence at the end, which the next write completes.
        std::size_t keep = 0;
        for (std::size_t k = 1; k <= 3 && k <= line_.size(); ++k) {
            const unsigned char c = static_cast<unsigned char>(line_[line_.size() - k]);
            if ((c & 0xc0) == 0xc0) {
                const std::size_t n = (c & 0xe0) == 0xc0 ? 2 : (c & 0xf0) == 0xe0 ? 3 : 4;
                if (n > k) keep = k;
                break;
            }
            if ((c & 0xc0) != 0x80) break;
        }
        emit(line_.size() - keep);
        return out_->pubsync();
    }

private:
    void emit(std::size_t n) {
        const std::string text = terminalText(std::string_view(line_).substr(0, n));
        out_->sputn(text.data(), std::streamsize(text.size()));
        line_.erase(0, n);
    }
    std::streambuf* out_;
    std::string line_;
};

}  // namespace

std::string terminalText(std::string_view text) {
    std::string out;
    out.reserve(text.size());
    for (std::size_t i = 0; i < text.size();) {
        char32_t cp = 0;
        const std::size_t n = utf8At(text, i, &cp);
        char buf[16];
        if (n == 0) {
            std::snprintf(buf, sizeof buf, "\\x%02x", static_cast<unsigned char>(text[i]));
            out += buf;
            ++i;
            continue;
        }
        if (mustEscape(cp)) {
            if (cp < 0x80) std::snprintf(buf, sizeof buf, "\\x%02x", unsigned(cp));
            else std::snprintf(buf, sizeof buf, "\\u%04x", unsigned(cp));
            out += buf;
        } else {
            out.append(text.substr(i, n));
        }
        i += n;
    }
    return out;
}

std::shared_ptr<void> escapeStream(std::ostream& stream) {
    auto buf = std::make_shared<EscapingBuf>(stream.rdbuf());
    stream.rdbuf(buf.get());
    std::ostream* s = &stream;
    return std::shared_ptr<void>(buf.get(), [buf, s](void*) {
        s->flush();
        s->rdbuf(buf->target());
    });
}

}  // namespace nephele::cli
