"""How far a run's fitted exposures lie from the true ones, on copies made by `fipt degrade`.

Usage: python3 scripts/gain_error.py FIPT COPY [COPY ...]

FIPT: the `fipt` binary; COPY: a folder `fipt degrade` wrote (its degrade.json holds each
view's true gain). Runs `FIPT info COPY --json` (a second or two: the fit of `fipt run`'s load
stage, without the light transport's contrast) and prints, per copy, the RMS and the largest
log error of the fitted gains against the true ones (both divided by their geometric mean),
and the same after the best power (slope): without known exposures the views fix the gains
only up to one.
"""
import json, subprocess, sys
import numpy as np

if len(sys.argv) < 3:
    sys.exit(__doc__)
fipt, copies = sys.argv[1], sys.argv[2:]
rms_all = []
for c in copies:
    d = json.load(open(f'{c}/degrade.json'))
    t = np.log([v['gain'] for v in d['views'] if v['split'] == 'train'])
    out = subprocess.run([fipt, 'info', c, '--json'], capture_output=True, text=True, check=True)
    fit = json.loads(out.stdout).get('exposure_fit')
    if not fit:
        print(f'{c}: no exposure fit')
        continue
    f = np.log(fit['gains'])
    t, f = t - t.mean(), f - f.mean()
    e = f - t
    slope = (f @ t) / (t @ t) if t @ t > 0 else 1.0
    es = f - slope * t
    rms = float(np.sqrt(np.mean(e ** 2)))
    rms_all.append(rms)
    print(f'{c:14s} true spread x{np.exp(t.max() - t.min()):.2f}  log error rms {rms:.4f} '
          f'max {np.abs(e).max():.4f}  | power {slope:.3f}: rms {np.sqrt(np.mean(es ** 2)):.4f}')
if rms_all:
    print(f'mean of the RMS: {np.mean(rms_all):.4f}')
