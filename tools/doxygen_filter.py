#!/usr/bin/python3
"""Doxygen's INPUT_FILTER for the public headers (docs/api.md): reads one header, writes it to
stdout with its plain `//` comments as Doxygen reads documentation, line for line (so that a
warning's line number is the header's). The headers keep the house style, plain `//` comments
saying why; this filter, not a second comment syntax in the sources, makes them the reference.

- The file's opening comment (its purpose, before any code) documents the file (`\\file`).
- A comment on lines of its own documents what follows it (`///`); one after a member, an
  enumerator or a parameter on the same line documents that (`///<`).
- A comment inside an inline function's body, after a line that declares nothing (a brace,
  a preprocessor line), or a section heading (`// ---- ...`) stays a plain comment.
"""
import re
import sys

SECTION = re.compile(r"^\s*// ?-{3,}")  # "// ---- The host API.": a heading for the reader of the header
TRAILING = re.compile(r'^(?P<code>.*?[;,])(?P<gap>\s*)//(?P<text>.*)$')


def strip_strings(line):
    """The line without its string and character literals (a `//` inside one is no comment), and
    without digit separators (20'000), which are not quotes."""
    line = re.sub(r"(?<=[0-9A-Fa-f])'(?=[0-9A-Fa-f])", "", line)
    return re.sub(r'"(?:\\.|[^"\\])*"|\'(?:\\.|[^\'\\])*\'', '""', line)


def code_flags(text):
    """A comment's command-line flags (--origin) as code, outside `code` already: Doxygen would
    print their two hyphens as a dash."""
    out, ticks = [], 0
    for part in re.split(r"(`|(?<![\w-])--[A-Za-z][\w-]*)", text):
        if part == "`":
            ticks += 1
        elif part.startswith("--") and ticks % 2 == 0:
            part = f"`{part}`"
        out.append(part)
    return "".join(out)


def doc(line, marker):
    """`line` (a comment line, or code with a trailing comment) with its `//` made `marker`."""
    code, _, text = line.partition("//")
    return f"{code}{marker}{code_flags(text)}"


def filter_header(lines):
    out = []
    opening = True   # still in the file's opening comment
    depth = 0        # braces open that are not a namespace, class, struct, union or enum
    scopes = []      # per open brace: True if it opens a function body (or any block in one)
    pending_scope = False  # the code since the last ';' / '{' / '}' names a namespace or a type
    for line in lines:
        stripped = line.strip()
        if opening:
            if stripped.startswith("//"):
                out.append(doc(line, "///"))
                continue
            if out:
                out[-1] = out[-1].rstrip("\n") + " \\file\n"
            opening = False
        code = strip_strings(line.split("//", 1)[0] if "//" in strip_strings(line) else line)
        in_body = any(scopes)
        if stripped.startswith("//"):
            plain = in_body or SECTION.match(line)
            out.append(line if plain else doc(line, "///"))
        else:
            m = TRAILING.match(line)
            if (m and not in_body and not stripped.startswith("#") and m.group("code").strip() not in ("}", "};")
                    and "//" not in strip_strings(m.group("code"))):
                out.append(f"{m.group('code')}{m.group('gap')}///<{code_flags(m.group('text'))}\n")
            else:
                out.append(line)
        # Follow the braces: a function body (or a lambda, an initialiser) is a scope whose
        # comments are not documentation.
        for token in re.findall(r"\b(?:namespace|class|struct|union|enum)\b|[{};]", code):
            if token == "{":
                scopes.append(in_body or not pending_scope)
                in_body = any(scopes)
                pending_scope = False
            elif token == "}":
                if scopes:
                    scopes.pop()
                in_body = any(scopes)
            elif token == ";":
                pending_scope = False
            else:
                pending_scope = True
    if opening and out:
        out[-1] = out[-1].rstrip("\n") + " \\file\n"
    return out


def main():
    with open(sys.argv[1], encoding="utf-8") as fh:
        sys.stdout.write("".join(filter_header(fh.readlines())))


if __name__ == "__main__":
    main()
