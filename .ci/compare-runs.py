#!/usr/bin/env python3
"""compare.py OLD NEW: every file under OLD against NEW; JSON compared with wall-clock keys removed."""
import json, os, sys
WALL = {"real_time_factor", "wall_s", "elapsed_s"}
def strip(x):
    if isinstance(x, dict):
        return {k: strip(v) for k, v in x.items() if k not in WALL}
    if isinstance(x, list):
        return [strip(v) for v in x]
    return x
def load(p):
    t = open(p, encoding="utf-8", errors="replace").read()
    try:
        return strip(json.loads(t))
    except Exception:
        lines = [json.loads(l) for l in t.splitlines() if l.strip().startswith("{")] if t.strip().startswith("{") else None
        return [strip(l) for l in lines] if lines else t
old, new = sys.argv[1], sys.argv[2]
bad = n = 0
for root, _, files in os.walk(old):
    for f in files:
        p = os.path.join(root, f); q = os.path.join(new, os.path.relpath(p, old))
        if f.endswith(".err") or f.endswith(".png"): continue
        n += 1
        if not os.path.exists(q):
            print("MISSING", q); bad += 1; continue
        a, b = load(p), load(q)
        if a != b:
            bad += 1
            print("DIFF", os.path.relpath(p, old))
print(f"{n - bad} of {n} files identical")
sys.exit(1 if bad else 0)
