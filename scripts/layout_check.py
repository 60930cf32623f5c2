#!/usr/bin/env python3
"""The layout of include/isin (docs/design.md, "Layout"), checked from the files themselves.

    python3 scripts/layout_check.py [DIR]    exit 1 and one line per finding if the layout is broken
                                             (DIR: the headers' folder, include/isin by default)

Fails on:
  - an include cycle between headers;
  - a cycle between units, a unit being a folder (bvh/, io/, ...) or a top-level header;
  - a simd/ header including outside simd/, a detail/ header including outside detail/ and simd/;
  - an io/ header included from outside io/ and isin.hpp (file code is compiled once);
  - a header over MAX_LINES lines, a function over MAX_FUNCTION_LINES lines (counted from the
    line that opens its body to the line that closes it, by brace counting).
KNOWN lists what is above a size limit today, with its size then: it may shrink, not grow, and
a new entry is a finding. ALLOWED lists the include edges the rules above allow by name.
"""
import os
import re
import sys

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "include", "isin")
MAX_LINES = 800
MAX_FUNCTION_LINES = 120

# Include edges allowed by name, each with why.
ALLOWED = {
    # Bvh::save and load are file code; the header keeps its public name under bvh/.
    ("bvh/serialize.hpp", "io/file.hpp"),
}

# What exceeds a size limit today: header -> lines, (header, function name) -> lines.
KNOWN_HEADERS = {
}
KNOWN_FUNCTIONS = {
}

INCLUDE = re.compile(r'^\s*#\s*include\s*([<"])([^>"]+)[>"]')


def headers():
    out = []
    for base, _, files in os.walk(ROOT):
        for name in files:
            if name.endswith(".hpp"):
                out.append(os.path.relpath(os.path.join(base, name), ROOT).replace(os.sep, "/"))
    return sorted(out)


def includes(header, known):
    """The isin headers `header` includes, as paths relative to include/isin."""
    out = []
    with open(os.path.join(ROOT, header), encoding="utf-8") as f:
        for line in f:
            m = INCLUDE.match(line)
            if not m:
                continue
            kind, path = m.groups()
            if kind == "<":
                if not path.startswith("isin/"):
                    continue
                target = path[len("isin/"):]
            else:
                target = os.path.normpath(os.path.join(os.path.dirname(header), path)).replace(os.sep, "/")
            if target in known:
                out.append(target)
    return out


def cycles(graph):
    """Strongly connected components of more than one node (or with a self edge), by Tarjan."""
    index, low, stack, on, found = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1 or v in graph.get(v, ()):
                found.append(sorted(component))

    sys.setrecursionlimit(10000)
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def unit(header):
    return header.split("/")[0] + "/" if "/" in header else header


def strip(text):
    """`text` with comments, string and character literals blanked, newlines kept."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append("\n" * text.count("\n", i, j))
            i = j
        elif c == 'R' and text.startswith('R"', i):
            m = re.match(r'R"([^(\s]*)\(', text[i:])
            end = text.find(")" + m.group(1) + '"', i) if m else -1
            j = n if end < 0 else end + len(m.group(1)) + 2
            out.append("\n" * text.count("\n", i, j))
            i = j
        elif c in "\"'":
            if c == "'" and i > 0 and (text[i - 1].isalnum()) and i + 1 < n and text[i + 1].isalnum():
                out.append(" ")  # a digit separator: 1'000
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            out.append(" ")
            i = j + 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


SCOPE = re.compile(r"^(?:(?:inline|export)\s+)?(namespace|struct|class|union|enum|extern\s+\"?)\b")
TEMPLATE = re.compile(r"^template\s*<")


def head_kind(head):
    """'scope', 'function' or 'other' for the text before a '{' (at namespace or class scope)."""
    head = " ".join(head.split())
    while TEMPLATE.match(head):  # drop template <...> prefixes
        depth, k = 0, head.index("<")
        for k in range(k, len(head)):
            depth += {"<": 1, ">": -1}.get(head[k], 0)
            if depth == 0:
                break
        head = head[k + 1:].strip()
    if SCOPE.match(head) or head.startswith('extern "C'):
        return "scope"
    if ")" in head and not head.startswith("="):
        return "function"
    return "other"


NAME = re.compile(r"([~\w:]+(?:\s*<[^()]*>)?|operator\s*[^\s(]+)\s*\($")


def name_of(head):
    """The function's name in its signature: the word before the first parenthesis."""
    head = " ".join(head.split())
    for k, c in enumerate(head):
        if c == "(":
            m = NAME.search(head[: k + 1])
            return m.group(1) if m else head[:k].split(" ")[-1]
    return head[:40]


def functions(text):
    """(signature line, last line, body line, name) of each function body at scope level."""
    lines = strip(text).split("\n")
    found, stack, head, head_line = [], [], [], None
    for number, line in enumerate(lines, 1):
        if line.lstrip().startswith("#"):
            continue
        for c in line:
            in_function = any(kind == "function" for kind, _, _, _ in stack)
            parens = head.count("(") - head.count(")")
            if in_function and c not in "{}":
                continue
            if c in "{};" and parens > 0 and not in_function:  # in a signature: a default `= {}`
                head.append(c)
            elif c == "{":
                text_of_head = "".join(head)
                kind = "block" if in_function else head_kind(text_of_head)
                stack.append((kind, number, head_line or number, name_of(text_of_head)))
                head, head_line = [], None
            elif c == "}":
                if stack:
                    kind, first, start, name = stack.pop()
                    if kind == "function":
                        found.append((start, number, first, name))
                head, head_line = [], None
            elif c == ";":
                head, head_line = [], None
            else:
                if head_line is None and not c.isspace():
                    head_line = number
                head.append(c)
        head.append(" ")
    return found


def main():
    global ROOT
    if len(sys.argv) > 1:
        ROOT = sys.argv[1]
    known = headers()
    graph = {h: includes(h, set(known)) for h in known}
    problems = []

    for component in cycles(graph):
        problems.append("include cycle: " + " -> ".join(component))

    units = {}
    for h, targets in graph.items():
        for t in targets:
            if (h, t) not in ALLOWED and unit(h) != unit(t):
                units.setdefault(unit(h), set()).add(unit(t))
    for component in cycles(units):
        problems.append("cycle between units: " + " -> ".join(component))

    for h, targets in graph.items():
        for t in targets:
            if (h, t) in ALLOWED:
                continue
            if h.startswith("simd/") and not t.startswith("simd/"):
                problems.append(f"{h} includes {t}: simd/ includes only simd/")
            if h.startswith("detail/") and not t.startswith(("detail/", "simd/")):
                problems.append(f"{h} includes {t}: detail/ includes only detail/ and simd/")
            if t.startswith("io/") and not (h.startswith("io/") or h == "isin.hpp"):
                problems.append(f"{h} includes {t}: io/ is included only from io/ and isin.hpp")

    for h in known:
        with open(os.path.join(ROOT, h), encoding="utf-8") as f:
            text = f.read()
        count = text.count("\n")
        limit = max(MAX_LINES, KNOWN_HEADERS.get(h, 0))
        if count > limit:
            problems.append(f"{h}: {count} lines (at most {limit})")
        for start, end, first, name in functions(text):
            length = end - first + 1
            limit = max(MAX_FUNCTION_LINES, KNOWN_FUNCTIONS.get((h, name), 0))
            if length > limit:
                problems.append(f"{h}:{start}: {name}: a function of {length} lines (at most {limit})")

    for p in problems:
        print("layout: " + p)
    if problems:
        return 1
    print(f"layout: {len(known)} headers: no include cycle, no cycle between folders, detail/, simd/ "
          f"and io/ where they belong, no header over {MAX_LINES} lines, no function over "
          f"{MAX_FUNCTION_LINES} (besides those listed in scripts/layout_check.py)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
