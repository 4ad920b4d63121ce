#!/usr/bin/env python3
"""Size figures of `src/`: `pub` items outside `cli/`, the longest functions, files over 1,000 lines.

    python3 scripts/code_stats.py [SRC_DIR] [--top N]
    rm -rf target/doc/mosaicd && cargo doc --no-deps --lib && python3 scripts/code_stats.py --rustdoc target/doc/mosaicd

`--rustdoc DOC_DIR` counts the library's public API as rustdoc sees it instead: one page per public
item (`struct.*.html`, `fn.*.html`, `enum.*`, `trait.*`, `type.*`, `constant.*`, `static.*`,
`macro.*`, `union.*`, `traitalias.*`) and one `index.html` per public module, in total and per
top-level module. An item re-exported from a private module gets its page at the re-export; an item
reachable by two public paths has one page, where it is defined. The redirect pages rustdoc leaves at
a re-exported item's private path are not counted. Pass the `doc/<crate>` directory of
the target dir cargo used (`$CARGO_TARGET_DIR/doc/mosaicd`), removed first: rustdoc leaves the pages
of items that are no longer public in place.

`pub` items are lines that start (after indentation) with `pub ` followed by an item keyword (fn,
struct, enum, trait, type, const, static, mod, use, union) or a field (`pub name:`), outside
`#[cfg(test)]` modules; `pub(crate)` and `pub(super)` are counted apart. Function length is from the
`fn` line to its closing brace, tests excluded. File length counts every line; the lines before the
first `#[cfg(test)]` module are given too.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from module_graph import strip_comments_and_strings, strip_test_modules  # noqa: E402

PUB_ITEM = re.compile(
    r"^\s*pub(\((crate|super)\))?\s+(?:(?:unsafe|async|const|extern\s+\"[^\"]*\")\s+)*"
    r"(fn|struct|enum|trait|type|const|static|mod|use|union)\b"
)
PUB_FIELD = re.compile(r"^\s*pub(\((crate|super)\))?\s+[a-z_][a-z0-9_]*\s*:")
FN = re.compile(r"\bfn\s+([A-Za-z_][A-Za-z0-9_]*)")


def functions(code: str):
    """(name, first line, number of lines) of every function with a body."""
    out = []
    for m in FN.finditer(code):
        # the body starts at the first `{` after the signature, unless a `;` comes first
        i = m.end()
        depth_paren = 0
        while i < len(code):
            c = code[i]
            if c in "(<[":
                depth_paren += 1
            elif c in ")>]":
                depth_paren -= 1
            elif c == ";" and depth_paren <= 0:
                i = -1
                break
            elif c == "{" and depth_paren <= 0:
                break
            i += 1
        if i < 0 or i >= len(code):
            continue
        depth, j = 1, i + 1
        while j < len(code) and depth:
            depth += {"{": 1, "}": -1}.get(code[j], 0)
            j += 1
        first = code.count("\n", 0, m.start()) + 1
        last = code.count("\n", 0, j) + 1
        out.append((m.group(1), first, last - first + 1))
    return out


ITEM_PAGE = re.compile(r"^(struct|fn|enum|trait|type|constant|static|macro|union|traitalias)\.[^.]+\.html$")


def rustdoc_counts(doc: Path) -> int:
    """Prints the public items rustdoc documents under `doc` (see the module docs)."""
    if not (doc / "index.html").is_file():
        print(f"{doc}: no rustdoc output (run `cargo doc --no-deps --lib` first)", file=sys.stderr)
        return 2
    kinds: dict[str, int] = {}
    per_top: dict[str, int] = {}
    modules = 0
    for f in sorted(doc.rglob("*.html")):
        rel = f.relative_to(doc)
        top = rel.parts[0] if len(rel.parts) > 1 else "(crate root)"
        if f.name == "index.html":
            if len(rel.parts) > 1:
                modules += 1
                per_top[top] = per_top.get(top, 0) + 1
            continue
        m = ITEM_PAGE.match(f.name)
        if m and f.stat().st_size < 2000 and "Redirecting to" in f.read_text(errors="replace"):
            continue  # the stub at a private path of an item re-exported elsewhere
        if m:
            kinds[m.group(1)] = kinds.get(m.group(1), 0) + 1
            per_top[top] = per_top.get(top, 0) + 1
    items = sum(kinds.values())
    print(f"public API (rustdoc pages): {items} items and {modules} modules")
    print("  by kind: " + ", ".join(f"{k} {n}" for k, n in sorted(kinds.items(), key=lambda kv: -kv[1])))
    print("  by top-level module (items + modules):")
    for top, n in sorted(per_top.items(), key=lambda kv: (-kv[1], kv[0])):
        print(f"    {n:5} {top}")
    return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("src", nargs="?", default=str(Path(__file__).resolve().parent.parent / "src"))
    ap.add_argument("--top", type=int, default=10)
    ap.add_argument("--rustdoc", metavar="DOC_DIR", help="count the public items in this rustdoc output instead")
    args = ap.parse_args()
    if args.rustdoc:
        return rustdoc_counts(Path(args.rustdoc))
    src = Path(args.src)
    pub = {"pub": 0, "pub(crate)": 0, "pub(super)": 0}
    pub_fields = 0
    fns = []
    big = []
    for f in sorted(src.rglob("*.rs")):
        rel = f.relative_to(src)
        text = f.read_text()
        code = strip_test_modules(strip_comments_and_strings(text))
        n_lines = text.count("\n")
        if n_lines > 1000:
            m = re.search(r"(?m)^\s*#\[cfg\(test\)\]\s*\n\s*mod\s", text)
            before = text.count("\n", 0, m.start()) if m else n_lines
            big.append((n_lines, before, str(rel)))
        for name, line, length in functions(code):
            fns.append((length, f"{rel}:{line}", name))
        if rel.parts[0] == "cli" or rel.name == "main.rs":
            continue
        for line in code.splitlines():
            m = PUB_ITEM.match(line)
            if not m and PUB_FIELD.match(line):
                pub_fields += PUB_FIELD.match(line).group(2) is None
                continue
            if m:
                pub[{None: "pub", "crate": "pub(crate)", "super": "pub(super)"}[m.group(2)]] += 1
    print(
        f"pub items outside cli/: {pub['pub']} pub, {pub['pub(crate)']} pub(crate), {pub['pub(super)']} pub(super);"
        f" and {pub_fields} pub fields"
    )
    print(f"files over 1,000 lines: {len(big)}")
    for n, before, rel in sorted(big, reverse=True):
        print(f"  {n:5} {rel} ({before} before its tests)")
    print(f"longest functions (tests excluded), top {args.top}:")
    for length, where, name in sorted(fns, reverse=True)[: args.top]:
        print(f"  {length:4} {name} ({where})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
