#!/usr/bin/env python3
"""Import circles between the files of a Rust crate.

usage: import-cycles.py SRC_DIR [SRC_DIR ...]   (each the `src/` of one crate)

A file depends on another when it names an item of it by path: `crate::a::b::Item`,
`super::x::Item`, `self::x::Item` (in `use` or inline), or a sibling module's name through a
`use` of its parent's. Each path is resolved to the deepest module file that exists; an item
defined in a `mod.rs`/`lib.rs` resolves to that file. Exit 1 and print each circle found
(strongly connected components of more than one file).
"""
import os, re, sys

def modules(src):
    """module path (tuple) -> file, for every .rs file under src."""
    out = {}
    for root, _, files in os.walk(src):
        for f in files:
            if not f.endswith(".rs"):
                continue
            rel = os.path.relpath(os.path.join(root, f), src)[:-3].split(os.sep)
            if rel == ["main"] and os.path.exists(os.path.join(src, "lib.rs")):
                continue  # the binary: a crate of its own beside the library
            if rel[-1] in ("mod", "lib", "main"):
                rel = rel[:-1]
            elif rel[0] == "bin":
                continue
            out[tuple(rel)] = os.path.join(root, f)
    return out

PATH = re.compile(r"\b(crate|super|self)((?:::\w+)+)")
USE_GROUP = re.compile(r"\buse\s+(crate|super|self)((?:::\w+)*)::\{([^;]*)\};", re.S)

def strip_comments(text):
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    return "\n".join(l.split("//")[0] for l in text.splitlines())

def resolve(mods, here, head, rest):
    if head == "crate":
        base = ()
    elif head == "self":
        base = here
    else:
        base = here[:-1]
        while rest and rest[0] == "super":
            base, rest = base[:-1], rest[1:]
    full = base + tuple(rest)
    for k in range(len(full), -1, -1):
        if full[:k] in mods:
            return full[:k]
    return None

def graph(src):
    mods = modules(src)
    edges = {m: set() for m in mods}
    for m, path in mods.items():
        here = m if os.path.basename(path) in ("mod.rs", "lib.rs", "main.rs") else m
        # Paths inside a file are relative to its own module.
        text = strip_comments(open(path, encoding="utf-8").read())
        refs = []
        for g in USE_GROUP.finditer(text):
            head, pre, body = g.group(1), [p for p in g.group(2).split("::") if p], g.group(3)
            for item in re.split(r",", re.sub(r"\{[^}]*\}", "", body)):
                item = item.strip().split(" as ")[0].strip()
                if item and item != "self":
                    refs.append((head, pre + [p for p in item.split("::") if p]))
                elif item == "self":
                    refs.append((head, pre))
        for p in PATH.finditer(text):
            refs.append((p.group(1), [x for x in p.group(2).split("::") if x]))
        for head, rest in refs:
            t = resolve(mods, m, head, rest)
            if t is not None and t != m:
                edges[m].add(t)
    return mods, edges

def sccs(edges):
    index, low, stack, on, out, i = {}, {}, [], set(), [], [0]
    def visit(v):
        index[v] = low[v] = i[0]; i[0] += 1; stack.append(v); on.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w); low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop(); on.discard(w); comp.append(w)
                if w == v:
                    break
            out.append(comp)
    sys.setrecursionlimit(10000)
    for v in edges:
        if v not in index:
            visit(v)
    return out

bad = 0
for src in sys.argv[1:]:
    mods, edges = graph(src)
    for comp in sccs(edges):
        if len(comp) > 1:
            bad += 1
            print(f"{src}: circle: " + " <-> ".join(sorted(os.path.relpath(mods[m], src) for m in comp)))
    print(f"{src}: {len(mods)} files, {sum(len(e) for e in edges.values())} file dependencies")
sys.exit(1 if bad else 0)
