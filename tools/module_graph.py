#!/usr/bin/env python3
"""Dependency graph between the crate's top-level modules (stdlib only).

A top-level module is one that src/lib.rs declares (`mod x;` / `pub mod x;`): src/x.rs and src/x/,
all submodules folded into x. src/main.rs and src/bin/ form one more node, `main`. A -> B when
code of A names B by `crate::B` / `$crate::B` (in `use` trees, grouped, nested or multi-line, and
inline paths; `crate::m!` of a `#[macro_export]` macro defined in B counts as B), by a `super::`
chain that climbs out of A to the crate root (inline `mod m { .. }` blocks count as a level), or,
for `main`, by `mesorheo::B`. A small lexer drops comments (nested `/* */`, doc comments included),
string, char and raw literals and lifetimes first. Self-edges are ignored. Not seen: `#[path]`,
modules written inline in lib.rs, names reached through `pub use` re-exports in lib.rs.

  python3 tools/module_graph.py [--root DIR] [--no-tests]   edges by module, cycle groups (Tarjan
        SCCs of size > 1) and their 2-cycles with one file:line per direction (or, without any
        2-cycle, one shortest cycle with evidence for each edge)
  ... --check      exit 1 printing the cycle groups, else 0: "no cycle among N top-level modules"
  ... --dot        Graphviz DOT, edges inside a cycle group in red
  ... --markdown   markdown summary
  ... --no-tests   leave `#[cfg(test)]` items (the unit-test modules) out
"""
import argparse
import bisect
import re
import sys
from pathlib import Path

TOKEN = re.compile(r"""
    (?P<ws>\s+) | (?P<line>//[^\n]*) | (?P<block>/\*)
  | (?P<raw>[bc]?r(?P<hashes>\#*)")
  | (?P<str>[bc]?"(?:\\.|[^"\\])*")
  | (?P<char>b?'(?:\\(?:x[0-9a-fA-F]{2}|u\{[0-9a-fA-F]*\}|.)|[^'\\\n])')
  | (?P<lifetime>'[A-Za-z_]\w*)
  | r\#(?P<rawid>[A-Za-z_]\w*) | (?P<id>[A-Za-z_]\w*) | (?P<num>\d\w*)
  | (?P<path>::) | (?P<punct>.)""", re.X | re.S)


def lex(text):
    """[(token, line)] with comments, literals and lifetimes removed."""
    starts = [i + 1 for i, c in enumerate(text) if c == "\n"]
    toks, i = [], 0
    while i < len(text):
        m = TOKEN.match(text, i)
        kind, end = m.lastgroup, m.end()
        if kind == "block":  # nested block comment
            depth = 1
            while depth and end < len(text):
                pair = text[end:end + 2]
                depth += (pair == "/*") - (pair == "*/")
                end += 2 if pair in ("/*", "*/") else 1
        elif m.group("raw") is not None:
            close = text.find('"' + m.group("hashes"), end)
            end = len(text) if close < 0 else close + 1 + len(m.group("hashes"))
        elif kind in ("rawid", "id", "path", "punct"):
            toks.append((m.group(kind), bisect.bisect_right(starts, i) + 1))
        i = end
    return toks


def module_files(src):
    """{top-level module: [(file, module path)]} from the `mod x;` lines of lib.rs, and main's files."""
    toks = [t for t, _ in lex((src / "lib.rs").read_text(encoding="utf-8"))]
    names = [toks[k + 1] for k in range(len(toks) - 2) if toks[k] == "mod" and toks[k + 2] == ";"]
    mods = {}
    for name in names:
        files = [src / f"{name}.rs"] * (src / f"{name}.rs").is_file() + sorted((src / name).rglob("*.rs"))
        parts = [list(f.relative_to(src).with_suffix("").parts) for f in files]
        mods[name] = [(f, p[:-1] if p[-1] == "mod" else p) for f, p in zip(files, parts)]
    main = [src / "main.rs"] * (src / "main.rs").is_file() + sorted((src / "bin").rglob("*.rs"))
    return mods, [(f, []) for f in main]


def drop_test_items(toks):
    """Remove the items under `#[cfg(test)]`: up to a `;` before any brace, or the first `{..}`."""
    out, k = [], 0
    while k < len(toks):
        if [t for t, _ in toks[k:k + 7]] != ["#", "[", "cfg", "(", "test", ")", "]"]:
            out.append(toks[k])
            k += 1
            continue
        k, depth = k + 7, 0
        while k < len(toks):
            tok = toks[k][0]
            k += 1
            depth += (tok == "{") - (tok == "}")
            if depth == 0 and tok in ";}":
                break
    return out


def first_segments(toks, j):
    """Top-level names a path continues with at toks[j]: `x` or the items of `{x::.., y, ..}`."""
    if j >= len(toks):
        return []
    if toks[j][0] != "{":
        return [toks[j]]
    out, depth, fresh = [], 0, True
    for tok in toks[j:]:
        if tok[0] in "{}":
            depth += 1 if tok[0] == "{" else -1
            if depth == 0:
                break
        elif depth == 1 and tok[0] == ",":
            fresh = True
        elif depth == 1 and fresh and tok[0] != "self":
            out.append(tok)
            fresh = False
    return out


def references(toks, path, is_main):
    """Yield (name, line) of each top-level name a file refers to; `path` is its module path."""
    depth, inline, pending = 0, [], None
    for k, (tok, line) in enumerate(toks):
        nxt = toks[k + 1][0] if k + 1 < len(toks) else ""
        if tok == "mod" and k + 2 < len(toks) and toks[k + 2][0] == "{":
            pending = nxt
        elif tok == "{":
            depth += 1
            if pending:
                inline.append((pending, depth))
                pending = None
        elif tok == "}":
            if inline and inline[-1][1] == depth:
                inline.pop()
            depth -= 1
        if nxt != "::" or (k and toks[k - 1][0] == "::" and tok != "mesorheo"):
            continue
        if is_main:
            if tok == "mesorheo":
                yield from first_segments(toks, k + 2)
        elif tok == "crate":
            yield from first_segments(toks, k + 2)
        elif tok == "super":
            j = k
            while j + 2 < len(toks) and toks[j][0] == "super" and toks[j + 1][0] == "::":
                j += 2
            if (j - k) // 2 == len(path) + len(inline):  # climbed to the crate root
                yield from first_segments(toks, j)


def build_graph(src, tests=True):
    """Sorted nodes and {(a, b): [(file, line), ..]} for the crate whose sources are in src."""
    mods, main = module_files(src)
    macros = {}  # #[macro_export] macro -> defining module (they live at the crate root)
    lexed = {}
    for name, files in list(mods.items()) + [("main", main)]:
        for f, path in files:
            toks = lex(f.read_text(encoding="utf-8"))
            toks = lexed[f] = toks if tests else drop_test_items(toks)
            for k in range(len(toks) - 6):
                if [t for t, _ in toks[k:k + 6]] == ["#", "[", "macro_export", "]", "macro_rules", "!"]:
                    macros[toks[k + 6][0]] = name
    edges = {}  # (a, b) -> [(file, line), ...]
    for name, files in list(mods.items()) + [("main", main)]:
        for f, path in files:
            for target, line in references(lexed[f], path, name == "main"):
                target = target if target in mods else macros.get(target)
                if target and target != name:
                    edges.setdefault((name, target), []).append((f.relative_to(src.parent).as_posix(), line))
    nodes = sorted(mods) + (["main"] if main else [])
    return nodes, edges


def tarjan(succ):
    """Strongly connected components with more than one node, largest first."""
    index, low, stack, on, comps = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in succ[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while not comp or comp[-1] != v:
                comp.append(stack.pop())
                on.discard(comp[-1])
            comps.append(sorted(comp))

    for v in succ:
        if v not in index:
            visit(v)
    return sorted((c for c in comps if len(c) > 1), key=lambda c: (-len(c), c))


def examples(comp, edges):
    """The group's 2-cycles [(a, b)]; without any, one shortest cycle through comp[0] as a path."""
    pairs = [(a, b) for a in comp for b in comp if a < b and (a, b) in edges and (b, a) in edges]
    if pairs:
        return pairs, None
    prev, todo = {}, [comp[0]]
    while comp[0] not in prev:  # BFS inside the group; it is strongly connected, so this ends
        v = todo.pop(0)
        for w in sorted(b for a, b in edges if a == v and b in comp and b not in prev):
            prev[w] = v
            todo.append(w)
    path = [comp[0]]
    while len(path) == 1 or path[-1] != comp[0]:
        path.append(prev[path[-1]])
    return [], path[::-1]


def ev(edges, a, b):
    """`file:line` of the first reference of a to b, and on how many more lines a refers to b."""
    f, line = edges[(a, b)][0]
    n = len(set(edges[(a, b)]))
    return f"{f}:{line}" + (f" (+{n - 1} more line{'s' * (n > 2)})" if n > 1 else "")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    mode = ap.add_mutually_exclusive_group()
    for flag in ("--check", "--dot", "--markdown"):
        mode.add_argument(flag, action="store_true")
    ap.add_argument("--no-tests", action="store_true", help="skip #[cfg(test)] items")
    ap.add_argument("--root", default=".", help="crate root (holds src/); default: .")
    args = ap.parse_args()
    nodes, edges = build_graph(Path(args.root) / "src", not args.no_tests)
    succ = {n: sorted(b for a, b in edges if a == n) for n in nodes}
    sccs = tarjan(succ)
    mods = len([n for n in nodes if n != "main"])
    if args.check:
        for i, comp in enumerate(sccs, 1):
            print(f"cycle group {i} ({len(comp)} modules): {', '.join(comp)}")
        if not sccs:
            print(f"no cycle among {mods} top-level modules")
        return 1 if sccs else 0
    if args.dot:
        cyc = {(a, b) for c in sccs for a in c for b in c}
        print("digraph modules {\n  rankdir=LR;\n  node [shape=box, fontname=monospace];")
        print("  " + " ".join(f'"{n}";' for n in nodes))
        for a, b in sorted(edges):
            print(f'  "{a}" -> "{b}"' + (" [color=red];" if (a, b) in cyc else ";"))
        print("}")
        return 0
    if args.markdown:
        print(f"- {mods} top-level modules" + (" (+ `main`)" if "main" in nodes else "")
              + f", {len(edges)} edges, {len(sccs)} cycle group(s)\n")
        for i, comp in enumerate(sccs, 1):
            print(f"**Cycle group {i}** ({len(comp)} modules): "
                  + ", ".join(f"`{m}`" for m in comp) + "\n")
            pairs, path = examples(comp, edges)
            print("| 2-cycle | A → B evidence | B → A evidence |\n|---|---|---|" if pairs else
                  "No 2-cycle; a shortest cycle: " + " → ".join(f"`{m}`" for m in path) + "\n")
            for a, b in pairs:
                print(f"| `{a}` ⇄ `{b}` | `{ev(edges, a, b)}` | `{ev(edges, b, a)}` |")
            for a, b in zip(path or [], (path or [])[1:]):
                print(f"- `{a}` → `{b}`: `{ev(edges, a, b)}`")
            print()
        print("<details><summary>All edges</summary>\n")
        for n in nodes:
            print(f"- `{n}` → " + (", ".join(succ[n]) or "—"))
        print("\n</details>")
        return 0
    for n in nodes:
        print(f"{n} -> " + (", ".join(succ[n]) or "(none)"))
    print(f"\n{mods} top-level modules, {len(edges)} edges, {len(sccs)} cycle group(s)")
    for i, comp in enumerate(sccs, 1):
        print(f"\ncycle group {i} ({len(comp)} modules): {', '.join(comp)}")
        pairs, path = examples(comp, edges)
        for a, b in pairs:
            print(f"  {a} <-> {b}\n    {a} -> {b}: {ev(edges, a, b)}\n    {b} -> {a}: {ev(edges, b, a)}")
        if path:
            print("  no 2-cycle; a shortest cycle: " + " -> ".join(path))
            for a, b in zip(path, path[1:]):
                print(f"    {a} -> {b}: {ev(edges, a, b)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
