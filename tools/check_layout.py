#!/usr/bin/python3
"""The libraries' boundaries, checked from their #include lines (docs/architecture.md).

Run: `cmake --build build --target check-layout`, `ctest -R LayoutCheck`, or
`/usr/bin/python3 tools/check_layout.py [repo root]`. Exit 0 when the layout holds; 1 with one
line per broken rule (file:line, what it includes, which rule) otherwise.

Rules:
1. A library includes another library's src/ neither by a relative path nor by name: each
   library's src/ is its own (the build puts it on that library's include path alone, so a
   name include fails to compile too; a relative path would not).
2. A library includes only the public headers (<lib>/include/nephele/) and the shared internal
   headers (<lib>/internal/) of the libraries it depends on, per DEPENDS below; in particular
   core/ includes no model header (core knows no rendering method and no model).
3. A public header (under */include/) includes public headers only: no src/ or internal/
   header, and it declares nothing in namespace detail.
4. The installed headers are a curated list, nephele_public_headers(...) in each library's
   CMakeLists.txt: every header in <lib>/include/nephele/ is on it and everything on it exists.
5. Every public and shared internal header declares between NEPHELE_API_BEGIN and
   NEPHELE_API_END (nephele/api.hpp): the libraries are built with hidden symbols, and a shared
   build exports what those headers declare, nothing else.

Seen failing, each broken on a copy of the tree and run there (then LayoutCheck fails the same):
- `#include "../../ellipsoid/src/packer.hpp"` in volume/src/raymarch.cpp: "volume/src/raymarch.cpp:10:
  includes ellipsoid/src/packer.hpp: another library's src/ (private to ellipsoid)";
- `#include "nephele/noise.hpp"` in core/src/scene.cpp: "core may not include model (core depends
  on nothing)";
- `#include "light_cache.hpp"` in model/include/nephele/cloud_radiance.hpp: "a public header includes
  an internal one";
- `#include "nephele/ellipsoid.hpp"` in reference/src/pathtrace.cpp: "reference may not include
  ellipsoid";
- a header added to model/include/nephele/ and not listed, and one listed and absent: both named;
- `#include "../../shaders/layer_light.glsl"` in layered/src/layer_model.hpp (the one-source GLSL by
  a relative path, not the build's copy): "includes shaders/layer_light.glsl: outside the libraries".
The tree before model/ existed (main at 31b02d7) gave 27 broken rules, among them
layered/src/layer_light.cpp including ellipsoid/src/photon_sampling.hpp, the path tracer including
nephele/gardner.hpp and nephele/projection.hpp, and detail:: in nephele/pathtrace.hpp.
"""
import os
import re
import sys

# The libraries and what each may include, besides itself (the dependency graph of
# docs/architecture.md). reference -> layered: the layers' density as the layered sky reads it
# (nephele/layered.hpp), which has not moved into model/ yet.
DEPENDS = {
    "core": [],
    "platform": ["core"],
    "model": ["core"],
    "ellipsoid": ["core", "model"],
    "volume": ["core", "model"],
    "layered": ["core", "model"],
    "sky": ["core", "model", "ellipsoid", "layered"],
    "reference": ["core", "model", "layered"],
}
INCLUDE = re.compile(r'^\s*#\s*include\s*"([^"]+)"')
SOURCES = (".cpp", ".hpp", ".h", ".inl")


def library_of(path, root):
    rel = os.path.relpath(path, root).split(os.sep)
    return (rel[0], rel[1]) if len(rel) > 2 and rel[0] in DEPENDS else (None, None)


def resolve(name, file_dir, lib, root):
    """Where `#include "name"` in a file of `lib` finds its file: the file's own folder, its
    library's src/, any library's include/ or internal/, any library's src/ (only to name the
    error), or nothing (a system or generated header)."""
    if "/" in name and name.startswith(".."):
        p = os.path.normpath(os.path.join(file_dir, name))
        return p if os.path.exists(p) else None
    candidates = [os.path.join(file_dir, name), os.path.join(root, lib, "src", name)]
    for other in DEPENDS:
        candidates += [os.path.join(root, other, "include", name), os.path.join(root, other, "internal", name)]
    for other in DEPENDS:
        candidates.append(os.path.join(root, other, "src", name))
    for c in candidates:
        if os.path.isfile(c):
            return os.path.normpath(c)
    return None


def public_header_list(root, lib):
    """The names in the library's nephele_public_headers(...) call, or None without one."""
    path = os.path.join(root, lib, "CMakeLists.txt")
    if not os.path.isfile(path):
        return None
    with open(path, encoding="utf-8") as fh:
        text = re.sub(r"#[^\n]*", "", fh.read())
    calls = re.findall(r"nephele_public_headers\(([^)]*)\)", text)
    return None if not calls else [n for c in calls for n in c.split()]


def check(root):
    errors = []
    for lib in DEPENDS:
        inc = os.path.join(root, lib, "include", "nephele")
        present = sorted(f for f in os.listdir(inc) if f.endswith(SOURCES)) if os.path.isdir(inc) else []
        listed = public_header_list(root, lib)
        if listed is None:
            if present:
                errors.append(f"{lib}/CMakeLists.txt: no nephele_public_headers(...) for {lib}/include/nephele/")
            continue
        for name in sorted(set(present) - set(listed)):
            errors.append(f"{lib}/include/nephele/{name}: not in {lib}'s nephele_public_headers (not installed)")
        for name in sorted(set(listed) - set(present)):
            errors.append(f"{lib}/CMakeLists.txt: nephele_public_headers lists {name}, not in {lib}/include/nephele/")
    for lib in DEPENDS:
        for dirpath, _, files in os.walk(os.path.join(root, lib)):
            for f in sorted(files):
                if not f.endswith(SOURCES):
                    continue
                path = os.path.join(dirpath, f)
                rel = os.path.relpath(path, root)
                public = rel.split(os.sep)[1] == "include"
                with open(path, encoding="utf-8", errors="replace") as fh:
                    text = fh.read()
                    lines = text.split("\n")
                exported = public or rel.split(os.sep)[1] == "internal"
                if exported and f != "api.hpp" and not ("\nNEPHELE_API_BEGIN\n" in text and "\nNEPHELE_API_END" in text):
                    errors.append(f"{rel}: declares outside NEPHELE_API_BEGIN ... NEPHELE_API_END (nephele/api.hpp): "
                                  "a shared build would hide it")
                for n, line in enumerate(lines, 1):
                    if public and re.search(r"\bnamespace\s+detail\b|\bdetail::", line.split("//")[0]):
                        errors.append(f"{rel}:{n}: a public header declares or uses namespace detail (internal)")
                    m = INCLUDE.match(line)
                    if not m:
                        continue
                    target = resolve(m.group(1), dirpath, lib, root)
                    if target is None:
                        continue  # system or generated (gl_functions.hpp, the GLSL copies)
                    trel = os.path.relpath(target, root)
                    tlib, tkind = library_of(target, root)
                    where = f"{rel}:{n}: includes {trel}"
                    if tlib is None:
                        # shaders/ too: a GLSL source compiled as C++ is included as the build's
                        # copy, "nephele/<file>.glsl" (nephele_glsl_sources, shaders/CMakeLists.txt).
                        errors.append(f"{where}: outside the libraries")
                        continue
                    if public and tkind != "include":
                        errors.append(f"{where}: a public header includes an internal one")
                    if tlib == lib:
                        continue
                    if tkind == "src":
                        errors.append(f"{where}: another library's src/ (private to {tlib})")
                    elif tlib not in DEPENDS[lib]:
                        deps = ", ".join(DEPENDS[lib]) or "nothing"
                        errors.append(f"{where}: {lib} may not include {tlib} ({lib} depends on {deps})")
    return errors


def main():
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), ".."))
    errors = check(root)
    for e in errors:
        print(e)
    if errors:
        print(f"check-layout: {len(errors)} broken rule(s); see tools/check_layout.py and docs/architecture.md")
        return 1
    print("check-layout: every library keeps to its boundaries")
    return 0


if __name__ == "__main__":
    sys.exit(main())
