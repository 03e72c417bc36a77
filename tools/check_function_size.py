#!/usr/bin/python3
"""No function in the libraries over 80 lines (issue #36 §5; docs/testing.md, "Form checks").

Run: `cmake --build build --target check-function-size`, `ctest -R FunctionSize`, or
`python3 tools/check_function_size.py [--list] [repo root]` (--list: every function found and
its length). Exit 0 when every function is within the
limit; 1 with one line per function over it ("file:line: name is N lines (limit 80)"), and one
per exception below that no longer names a long function (so the list only shrinks).

A function's length is clang-tidy's readability-function-size "lines" (the .clang-tidy at the
repository root is the definition this script follows): the line of its body's closing brace
minus the line of its opening brace, so comments and blank lines count, and a lambda counts as
part of the function it is written in (clang-tidy ignores lambdas as functions of their own).
The line reported is the line of the function's name, where clang-tidy reports it.

This is a brace scanner, not a C++ parser: comments, string and character literals and
preprocessor lines are blanked first; then, outside functions, a `{` opens a function body when
the text before it (since the last `;` or `}`) is a declarator, `name(...)`, followed only by
qualifiers, a trailing return type or a constructor's initializer list. Namespaces, classes,
structs, unions and enums are scanned into; initializers and namespace-scope lambdas are skipped.
"""
import bisect
import os
import re
import sys

LIMIT = 80
LIBRARIES = ["core", "model", "ellipsoid", "layered", "volume", "sky", "reference", "platform", "cigi/src"]
SOURCES = (".cpp", ".hpp", ".h", ".inl", ".cc")

# Functions allowed over the limit: (file, qualified name as written at its definition) -> why.
# Only for what cannot be split sensibly, or is being split elsewhere; an entry that no longer
# names a long function fails the check, so that it is removed.
EXCEPTIONS: dict = {}

# Comments, literals and preprocessor lines (with continuations), blanked before the scan.
# A quote after a digit or letter is a digit separator (16'000'000), not a character literal.
BLANKED = re.compile(
    r"""//[^\n]*
      | /\*.*?\*/
      | R"(?P<delim>[^()\\\s]{0,16})\(.*?\)(?P=delim)"
      | "(?:[^"\\\n]|\\.)*"
      | (?<![\w'])(?:u8|u|U|L)?'(?:[^'\\\n]|\\.)*'
      | ^[ \t]*\#(?:[^\n\\]|\\.|\\\n)*""",
    re.S | re.M | re.X,
)
SCOPE = re.compile(r"^(?:(?:inline|export)\s+)*(?:namespace|class|struct|union|enum|extern)\b")
TEMPLATE = re.compile(r"^template\s*<")
ACCESS = re.compile(r"\b(?:public|private|protected)\s*:(?!:)")
GROUP = re.compile(r"\([^()]*\)|\{[^{}]*\}|\[\[[^\[\]]*\]\]")
# After the parameter list: qualifiers, then optionally a trailing return type or a
# constructor's initializer list (members initialised by (...) or {...}, collapsed to () or {}).
QUALIFIERS = r"(?:\s*(?:const|volatile|noexcept\s*\x01?|override|final|&&|&|throw\s*\x01))*"
FUNCTION = re.compile(
    r"(?P<name>(?:~\s*)?[A-Za-z_][\w:<>,\s~*&]*?|operator\s*(?:\x01|[^\s\x01]+))\s*\x01" + QUALIFIERS +
    r"\s*(?:->[^;{}=]*|(?<!:):(?!:)(?:\s*[\w:<>.]+\s*[\x01\x02]\s*(?:\.\.\.)?\s*,?)+)?\s*$",
    re.S,
)
MACROS = re.compile(r"^(?:[A-Z][A-Z0-9_]+\s*\x01?\s*)+(?=\S)")
LAMBDA = re.compile(r"(?<!operator)\[[^\[\]]*\]\s*\x01?[^;{}\x01\x02\[\]]*$")


def blank(text):
    """The text with comments, literals and preprocessor lines blanked (newlines kept)."""
    def keep_lines(m):
        s = m.group(0)
        stripped = s.lstrip()
        if stripped.startswith(("//", "/*", "#")):
            return re.sub(r"[^\n]", " ", s)
        return '""' + "\n" * s.count("\n")  # a literal stays an expression: no brace, no semicolon
    return BLANKED.sub(keep_lines, text)


def collapse(head):
    """Nested (...) and {...} groups collapsed to one character each (\\x01, \\x02) and
    attributes [[...]] removed, innermost first."""
    mark = {"(": "\x01", "{": "\x02", "[": ""}
    while True:
        new = GROUP.sub(lambda m: mark[m.group(0)[0]], head)
        if new == head:
            return head
        head = new


def strip_template(head):
    """`template <...>` prefixes (angle brackets balanced) removed."""
    while TEMPLATE.match(head):
        depth, i = 0, head.index("<")
        for i in range(i, len(head)):
            depth += {"<": 1, ">": -1}.get(head[i], 0)
            if depth == 0:
                break
        head = head[i + 1:].lstrip()
    return head


def classify(head):
    """'scope', ('function', name) or 'other' for the `{` after `head` (outside any function)."""
    flat = collapse(ACCESS.sub(" ", head).strip())
    flat = MACROS.sub("", flat)  # NEPHELE_API_BEGIN and other macros without a semicolon
    flat = strip_template(flat)
    m = FUNCTION.search(flat)
    if SCOPE.match(flat) and not m:
        return "scope"
    if not m or LAMBDA.search(flat):
        return "other"
    before = flat[: m.start("name")]
    if "=" in before.replace("==", "").replace("operator=", ""):
        return "other"  # an initializer: `auto f = g() ...`
    name = m.group("name").strip()
    if not name.startswith("operator"):
        name = re.split(r"\s+", name)[-1]  # the words before it are its return type
    return ("function", re.sub(r"\s+", "", name))


def functions(path, text):
    """(line of name, length in lines, name) of every function body not inside another function."""
    clean = blank(text)
    newlines = [i for i, c in enumerate(clean) if c == "\n"]
    line = lambda pos: bisect.bisect_right(newlines, pos - 1) + 1
    close, stack = {}, []
    for m in re.finditer(r"[{}]", clean):
        if m.group(0) == "{":
            stack.append(m.start())
        elif not stack:
            raise ValueError(f"{path}:{line(m.start())}: unbalanced '}}'")
        else:
            close[stack.pop()] = m.start()
    if stack:
        raise ValueError(f"{path}:{line(stack[-1])}: unbalanced '{{'")
    found = []
    marks = re.compile(r"[{};]")

    def scan(start, end):
        boundary, pos = start, start
        while True:
            m = marks.search(clean, pos, end)
            if not m:
                return
            at = m.start()
            if m.group(0) != "{":
                boundary = pos = at + 1
                continue
            kind = classify(clean[boundary:at])
            if kind == "scope":
                scan(at + 1, close[at])
                boundary = close[at] + 1
            elif kind != "other":
                # Reported at its name, as clang-tidy does.
                last = re.escape(re.split(r"::", kind[1])[-1])
                named = re.search(r"(?<![\w])" + last + r"\s*\(", clean[boundary:at])
                found.append((line(boundary + named.start() if named else at), line(close[at]) - line(at), kind[1]))
                boundary = close[at] + 1
            pos = close[at] + 1  # an initializer's braces stay part of its declaration

    scan(0, len(clean))
    return found


def sources(root):
    for lib in LIBRARIES:
        for folder, dirs, files in os.walk(os.path.join(root, lib)):
            dirs.sort()
            for f in sorted(files):
                if f.endswith(SOURCES):
                    path = os.path.join(folder, f)
                    yield os.path.relpath(path, root).replace(os.sep, "/"), path


def main():
    args = sys.argv[1:]
    listing = "--list" in args  # every function found, with its length (to compare with clang-tidy)
    args = [a for a in args if a != "--list"]
    root = args[0] if args else os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    problems, excepted = [], set()
    for rel, path in sources(root):
        with open(path, encoding="utf-8") as f:
            text = f.read()
        try:
            found = functions(rel, text)
        except ValueError as e:
            problems.append(f"{e} (the scanner cannot read this file)")
            continue
        for at, lines, name in found:
            if listing:
                print(f"{lines:4d} {rel}:{at}: {name}")
            if lines <= LIMIT:
                continue
            if (rel, name) in EXCEPTIONS:
                excepted.add((rel, name))
                continue
            problems.append(f"{rel}:{at}: {name} is {lines} lines (limit {LIMIT}): split it into named phases")
    for key, why in EXCEPTIONS.items():
        if key not in excepted:
            problems.append(f"{key[0]}: {key[1]} is on the exception list ({why}) but is no longer over "
                            f"{LIMIT} lines (or gone): remove its entry")
    for p in problems:
        print(p)
    if problems:
        print(f"check_function_size: {len(problems)} problem(s); a function's length is clang-tidy's "
              f"readability-function-size lines (.clang-tidy)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
