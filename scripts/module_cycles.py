#!/usr/bin/env python3
"""Import cycles between the modules of each workspace crate.

A module's imports are the `crate::<module>` paths in its files (a folder module counts as
one), outside comments and `#[cfg(test)]` modules. Prints each strongly connected component
with its edges and exits 1 if there is one; prints nothing and exits 0 otherwise.

    python3 scripts/module_cycles.py        # from the workspace root
"""
import os
import re
import sys


def imports(crate):
    src = os.path.join(crate, "src")
    graph = {}
    for root, _, files in os.walk(src):
        for f in files:
            if not f.endswith(".rs"):
                continue
            path = os.path.join(root, f)
            parts = os.path.relpath(path, src)[:-3].split("/")
            if parts[-1] in ("mod", "lib", "main"):
                parts = parts[:-1]
            top = parts[0] if parts else "lib"
            text = open(path).read()
            cut = text.find("#[cfg(test)]")
            if cut >= 0:
                text = text[:cut]
            text = "\n".join(l for l in text.split("\n") if not l.strip().startswith("//"))
            deps = set(re.findall(r"crate::([a-z_0-9]+)", text))
            graph.setdefault(top, set()).update(d for d in deps if d != top)
    return graph


def components(graph):
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in graph:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in list(graph):
        if v not in index:
            visit(v)
    return out


found = False
crates = sorted(d for d in os.listdir(".") if d.startswith("fipt-"))
crates += [os.path.join("examples", d) for d in sorted(os.listdir("examples"))]
for crate in crates:
    if not os.path.isdir(os.path.join(crate, "src")):
        continue
    g = imports(crate)
    for comp in components(g):
        found = True
        edges = [(a, b) for a in comp for b in comp if b in g.get(a, ())]
        print(crate, comp, edges)
sys.exit(1 if found else 0)
