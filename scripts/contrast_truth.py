"""The light transport's contrast estimate against the truth, on copies made by `fipt degrade`.

Usage: python3 scripts/contrast_truth.py CONTRAST_CURVE COPY [COPY ...]

CONTRAST_CURVE: the `contrast_curve` example (`cargo build --release -p fipt-capture --example
contrast_curve`; target/release/examples/contrast_curve); COPY: a folder `fipt degrade --ldr
auto` wrote. Runs the example on each copy (its output is kept in COPY/contrast_curve.txt and
read from there on a second call) and prints, per copy:
- the response's outcome (`fipt run`'s load: "fitted" or sRGB kept);
- the truth: the power the views as decoded still need, the slope of the true exposures' logs
  (degrade.json) on the fitted gains' logs (the gains before the contrast raised them);
- the curve's lowest point and its depth (the spread at γ = 1 over the lowest), and whether
  the load applied it.
"""
import json, os, re, subprocess, sys
import numpy as np

if len(sys.argv) < 3:
    sys.exit(__doc__)
example, copies = sys.argv[1], sys.argv[2:]
print(f'{"copy":28s} {"response":8s} {"truth":>6s} {"estimate":>8s} {"depth %":>7s} applied')
for c in copies:
    out = os.path.join(c, 'contrast_curve.txt')
    if not os.path.exists(out):
        text = subprocess.run([example, c], capture_output=True, text=True, check=True).stdout
        with open(out + '.tmp', 'w') as f:
            f.write(text)
        os.replace(out + '.tmp', out)
    text = open(out).read()
    m = re.search(r'min gamma ([\d.]+) .*?= ([-\d.]+) %', text)
    est, depth = float(m.group(1)), float(m.group(2))
    ap = re.search(r'^applied (\w+) gamma ([\d.]+)', text, re.M)
    applied = bool(ap) and ap.group(1) == 'true'
    g = re.search(r'^gains \[(.*)\]', text, re.M)
    r = re.search(r'^response (\w+)', text, re.M)
    truth = float('nan')
    if g:
        fit = np.array([float(x) for x in g.group(1).split(',')])
        if applied:
            fit = fit ** (1.0 / float(ap.group(2)))
        true = np.array([v['gain'] for v in json.load(open(os.path.join(c, 'degrade.json')))['views']
                         if v['split'] == 'train'])
        if len(true) == len(fit) and np.std(np.log(fit)) > 0.05:
            truth = np.polyfit(np.log(fit), np.log(true), 1)[0]
    resp = r.group(1) if r else 'srgb'
    print(f'{os.path.basename(os.path.normpath(c)):28s} {resp:8s} {truth:6.3f} {est:8.3f} '
          f'{depth:7.2f} {"yes" if applied else "no"}')
