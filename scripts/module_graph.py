#!/usr/bin/env python3
"""The file-level import graph of `src/` and a check that it has no circle.

Every `.rs` file under `src/` is one node. An edge `a -> b` means code in file `a` names an item that
is defined in file `b`: through a `use` declaration (`crate::`, `super::`, `self::`, a child module,
or `mosaicd::` from the binary) or through a path written in the code (`crate::x::y`, `super::z`, or
a module imported by name, `detect::train::foo`). A name re-exported by a facade (`pub use` in a
`mod.rs`) resolves to the file that defines it, so facades do not count as dependencies, and a
facade's own `pub use` lines are not edges either. Code inside `#[cfg(test)]` modules is ignored:
tests may reach anywhere.

The graph's strongly connected components (Tarjan) of more than one file are the import circles.
The same check runs on the top-level modules (each folder of `src/` and each file at its root), where
a circle means two areas import each other even if no two files do.

Any circle fails the check, between files or between top-level modules: there is no list of
allowed ones. (A `#[cfg(test)] use` line outside a test module counts as an edge.)

    python3 scripts/module_graph.py            # exit 1 and list the circles if there is any
    python3 scripts/module_graph.py --edges    # also print every edge
    python3 scripts/module_graph.py --dot      # the graph in Graphviz form
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SRC = ROOT / "src"
# The binary is its own crate: its modules live under this prefix; `mosaicd::` from them is the lib.
BIN = "@bin"
LIB_NAME = "mosaicd"


def module_path(file: Path) -> tuple[str, ...]:
    rel = file.relative_to(SRC).with_suffix("")
    parts = list(rel.parts)
    if parts == ["lib"]:
        return ()
    if parts == ["main"]:
        return (BIN,)
    if parts[-1] == "mod":
        parts = parts[:-1]
    if parts[0] == "cli":
        return (BIN, *parts)
    return tuple(parts)


def strip_comments_and_strings(text: str) -> str:
    """Blanks comments, string and char literals (keeps line structure)."""
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
            continue
        if text.startswith("/*", i):
            depth, i = 1, i + 2
            while i < n and depth:
                if text.startswith("/*", i):
                    depth, i = depth + 1, i + 2
                elif text.startswith("*/", i):
                    depth, i = depth - 1, i + 2
                else:
                    if text[i] == "\n":
                        out.append("\n")
                    i += 1
            continue
        m = re.match(r'b?r(#*)"', text[i:i + 12])
        if m and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            end = '"' + m.group(1)
            j = text.find(end, i + m.end())
            j = n if j < 0 else j + len(end)
            out.append('""' + "\n" * text.count("\n", i, j))
            i = j
            continue
        if c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            out.append('""' + "\n" * text.count("\n", i, j))
            i = j + 1
            continue
        if c == "'":
            m = re.match(r"'(\\.|\\u\{[0-9a-fA-F]+\}|\\x[0-9a-fA-F]{2}|[^\\'])'", text[i:i + 12])
            if m:
                out.append("' '")
                i += m.end()
                continue
        out.append(c)
        i += 1
    return "".join(out)


def strip_test_modules(code: str) -> str:
    """Removes `#[cfg(test)] mod name { ... }` blocks and `#[cfg(test)] mod name;` lines."""
    out, pos = [], 0
    for m in re.finditer(r"#\[cfg\(test\)\]\s*(pub(\([^)]*\))?\s+)?mod\s+\w+\s*([;{])", code):
        if m.start() < pos:
            continue
        out.append(code[pos:m.start()])
        if m.group(3) == ";":
            pos = m.end()
            continue
        depth, j = 1, m.end()
        while j < len(code) and depth:
            depth += {"{": 1, "}": -1}.get(code[j], 0)
            j += 1
        out.append("\n" * code.count("\n", m.start(), j))
        pos = j
    out.append(code[pos:])
    return "".join(out)


def expand_use_tree(tree: str) -> list[tuple[list[str], str | None]]:
    """`a::{b, c::{d@e}, self}` -> [(path, None)]; `*` stays as a last segment (`@` marks `as`)."""
    tree = re.sub(r"\s+", "", tree)

    def split_top(s: str) -> list[str]:
        parts, depth, cur = [], 0, ""
        for ch in s:
            if ch == "{":
                depth += 1
            elif ch == "}":
                depth -= 1
            if ch == "," and depth == 0:
                parts.append(cur)
                cur = ""
            else:
                cur += ch
        if cur:
            parts.append(cur)
        return parts

    def rec(prefix: list[str], s: str):
        res = []
        brace = s.find("{")
        if brace >= 0 and s.endswith("}"):
            head = s[:brace].rstrip(":")
            segs = prefix + ([p for p in head.split("::") if p] if head else [])
            for part in split_top(s[brace + 1:-1]):
                res.extend(rec(segs, part))
            return res
        segs = prefix + [p for p in s.split("::") if p]
        if segs and segs[-1] == "self":
            segs = segs[:-1]
        return [(segs, None)]

    return rec([], tree)


USE_RE = re.compile(r"(?m)^\s*(pub(?:\([^)]*\))?\s+)?use\s+([^;]+);")
MOD_RE = re.compile(r"(?m)^\s*(?:pub(?:\([^)]*\))?\s+)?mod\s+(\w+)\s*;")
PATH_RE = re.compile(r"(?<![\w:])((?:crate|super|self|" + LIB_NAME + r")(?:::\w+)+)")


class Graph:
    def __init__(self, include_tests: bool):
        self.files: dict[tuple[str, ...], Path] = {}
        self.code: dict[tuple[str, ...], str] = {}
        for f in sorted(SRC.rglob("*.rs")):
            mp = module_path(f)
            self.files[mp] = f
            code = strip_comments_and_strings(f.read_text())
            if not include_tests:
                code = strip_test_modules(code)
            self.code[mp] = code
        # Re-exports: (module, name) -> absolute path; globs: module -> [absolute prefix]
        self.reexports: dict[tuple[tuple[str, ...], str], list[str]] = {}
        self.globs: dict[tuple[str, ...], list[list[str]]] = {}
        self.uses: dict[tuple[str, ...], list[tuple[list[str], bool]]] = {}
        for mp, code in self.code.items():
            items = []
            for m in USE_RE.finditer(code):
                is_pub = bool(m.group(1))
                for segs, _ in self.expand(m.group(2)):
                    absolute = self.absolutise(mp, segs)
                    if absolute is None:
                        continue
                    items.append((absolute, is_pub))
                    if is_pub:
                        if absolute and absolute[-1] == "*":
                            self.globs.setdefault(mp, []).append(absolute[:-1])
                        elif absolute:
                            name = self.use_name(m.group(2), segs)
                            self.reexports[(mp, name)] = absolute
            self.uses[mp] = items

    @staticmethod
    def expand(tree: str) -> list[tuple[list[str], str | None]]:
        # Handle `as` aliases before whitespace is squeezed.
        tree = re.sub(r"\s+as\s+(\w+)", r"@\1", tree)
        res = []
        for segs, _ in expand_use_tree(tree):
            alias = None
            if segs and "@" in segs[-1]:
                last, alias = segs[-1].split("@", 1)
                segs = segs[:-1] + [last]
            res.append((segs, alias))
        return res

    @staticmethod
    def use_name(tree: str, segs: list[str]) -> str:
        return segs[-1].split("@")[-1] if segs else ""

    def children(self, mp: tuple[str, ...]) -> set[str]:
        return {k[len(mp)] for k in self.files if len(k) == len(mp) + 1 and k[:len(mp)] == mp}

    def crate_root(self, mp: tuple[str, ...]) -> tuple[str, ...]:
        return (BIN,) if mp and mp[0] == BIN else ()

    def absolutise(self, mp: tuple[str, ...], segs: list[str]) -> list[str] | None:
        """A path as written in module `mp` -> an absolute path, or None for another crate."""
        if not segs:
            return None
        head = segs[0]
        if head == "crate":
            return list(self.crate_root(mp)) + segs[1:]
        if head == LIB_NAME and mp and mp[0] == BIN:
            return segs[1:]
        if head in ("super", "self"):
            base = list(mp)
            i = 0
            while i < len(segs) and segs[i] in ("super", "self"):
                if segs[i] == "super":
                    base = base[:-1]
                i += 1
            return base + segs[i:]
        if head in self.children(mp):
            return list(mp) + segs
        return None

    def resolve(self, path: list[str], depth: int = 0) -> tuple[str, ...] | None:
        """The file that defines the item at `path` (longest module prefix, through re-exports)."""
        if depth > 20:
            return None
        best = None
        for k in range(len(path), -1, -1):
            if tuple(path[:k]) in self.files:
                best = k
                break
        if best is None:
            return None
        mod = tuple(path[:best])
        rest = path[best:]
        if rest and rest[0] != "*":
            target = self.reexports.get((mod, rest[0]))
            if target is not None and target != list(mod) + [rest[0]]:
                return self.resolve(target + rest[1:], depth + 1)
            if target is None:
                for g in self.globs.get(mod, []):
                    r = self.resolve(g + rest, depth + 1)
                    if r is not None and r != mod:
                        return r
        return mod

    def edges(self) -> dict[tuple[str, ...], set[tuple[str, ...]]]:
        graph: dict[tuple[str, ...], set[tuple[str, ...]]] = {mp: set() for mp in self.files}
        for mp, code in self.code.items():
            aliases: dict[str, list[str]] = {c: list(mp) + [c] for c in self.children(mp)}
            for m in USE_RE.finditer(code):
                is_pub = bool(m.group(1))
                for segs, alias in self.expand(m.group(2)):
                    absolute = self.absolutise(mp, segs)
                    if absolute is None or not absolute:
                        continue
                    if absolute[-1] != "*":
                        aliases[alias or absolute[-1]] = absolute
                    if is_pub:
                        continue  # a facade's re-export is not a dependency of the facade
                    target = self.resolve(absolute)
                    if target is not None and target != mp:
                        graph[mp].add(target)
            body = USE_RE.sub("", code)
            body = MOD_RE.sub("", body)
            for m in PATH_RE.finditer(body):
                segs = m.group(1).split("::")
                absolute = self.absolutise(mp, segs)
                if absolute:
                    target = self.resolve(absolute)
                    if target is not None and target != mp:
                        graph[mp].add(target)
            names = "|".join(re.escape(a) for a in aliases if a not in ("crate", "super", "self"))
            if names:
                for m in re.finditer(r"(?<![\w:])(" + names + r")((?:::\w+)+)", body):
                    base = aliases[m.group(1)]
                    if tuple(base) not in self.files and not any(
                        tuple(base) == k[:len(base)] for k in self.files
                    ):
                        continue
                    absolute = base + m.group(2).split("::")[1:]
                    target = self.resolve(absolute)
                    if target is not None and target != mp:
                        graph[mp].add(target)
        return graph

    def name(self, mp: tuple[str, ...]) -> str:
        return str(self.files[mp].relative_to(SRC))


def strongly_connected(graph: dict) -> list[list]:
    index, low, on, stack, out = {}, {}, set(), [], []
    counter = [0]

    def visit(v):
        work = [(v, iter(sorted(graph[v])))]
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        while work:
            node, it = work[-1]
            advanced = False
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter[0]
                    counter[0] += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                    advanced = True
                    break
                if w in on:
                    low[node] = min(low[node], index[w])
            if advanced:
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                comp = []
                while True:
                    w = stack.pop()
                    on.discard(w)
                    comp.append(w)
                    if w == node:
                        break
                if len(comp) > 1:
                    out.append(comp)

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def shortest_cycle(graph, comp) -> list:
    """One short circle through the component, for the message."""
    members = set(comp)
    best = None
    for start in sorted(comp):
        prev = {start: None}
        queue = [start]
        found = None
        while queue and found is None:
            nxt = []
            for v in queue:
                for w in sorted(graph[v]):
                    if w not in members:
                        continue
                    if w == start:
                        found = v
                        break
                    if w not in prev:
                        prev[w] = v
                        nxt.append(w)
                if found is not None:
                    break
            queue = nxt
        if found is not None:
            cyc, v = [], found
            while v is not None:
                cyc.append(v)
                v = prev[v]
            cyc.reverse()
            if best is None or len(cyc) < len(best):
                best = cyc
    return best or sorted(comp)


def top_level(graph: dict) -> dict:
    """The graph collapsed to top-level modules (`detect`, `raw`, ..., `@bin` for the CLI)."""

    def top(mp):
        return mp[0] if mp else "lib.rs"

    out: dict = {}
    for a, bs in graph.items():
        out.setdefault(top(a), set())
        for b in bs:
            if top(a) != top(b):
                out[top(a)].add(top(b))
                out.setdefault(top(b), set())
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--edges", action="store_true", help="print every edge")
    ap.add_argument("--dot", action="store_true", help="print the graph in Graphviz form")
    ap.add_argument("--tests", action="store_true", help="count #[cfg(test)] modules too")
    args = ap.parse_args()
    g = Graph(include_tests=args.tests)
    graph = g.edges()
    if args.dot:
        print("digraph modules {")
        for a in sorted(graph):
            for b in sorted(graph[a]):
                print(f'  "{g.name(a)}" -> "{g.name(b)}";')
        print("}")
    if args.edges:
        for a in sorted(graph):
            for b in sorted(graph[a]):
                print(f"{g.name(a)} -> {g.name(b)}")
    failed = False
    n_edges = sum(len(v) for v in graph.values())
    comps = strongly_connected(graph)
    print(f"module graph: {len(graph)} files, {n_edges} edges, {len(comps)} import circle(s)")
    for comp in sorted(comps, key=lambda c: sorted(g.name(x) for x in c)):
        failed = True
        key = tuple(sorted(g.name(x) for x in comp))
        cyc = shortest_cycle(graph, comp)
        print(f"  circle of {len(comp)} files: " + ", ".join(key))
        print("    e.g. " + " -> ".join(g.name(x) for x in cyc + [cyc[0]]))
    tops = top_level(graph)
    top_comps = strongly_connected(tops)
    print(f"top-level modules: {len(tops)}, {len(top_comps)} circle(s)")
    for comp in sorted(top_comps, key=sorted):
        failed = True
        cyc = shortest_cycle(tops, comp)
        print("  circle: " + " -> ".join(cyc + [cyc[0]]))
        for a in sorted(comp):
            for b in sorted(comp - {a} if isinstance(comp, set) else set(comp) - {a}):
                if b not in tops[a]:
                    continue
                files = sorted(
                    f"{g.name(x)} -> {g.name(y)}"
                    for x in graph
                    for y in graph[x]
                    if (x[0] if x else "lib.rs") == a and (y[0] if y else "lib.rs") == b
                )
                for f in files:
                    print(f"    {f}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
