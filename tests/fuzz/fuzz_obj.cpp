// libFuzzer: the OBJ reader of the mesh generator on any bytes, then the mesh's ellipsoids
// (Steiner circumellipses). An ObjError is the expected way to fail.
#include "obj_reader.hpp"

#include <cstddef>
#include <cstdint>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    try {
        const nephele::detail::ObjMesh mesh =
            nephele::detail::parseObj(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.obj");
        nephele::Generator g;
        g.type = nephele::Generator::Type::Mesh;
        g.scale = 3;
        g.rotationDeg = {10, 20, 30};
        nephele::detail::meshCloud(mesh, g);
    } catch (const nephele::ObjError&) {}
    return 0;
}
