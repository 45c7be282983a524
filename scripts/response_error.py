"""How far a run's fitted camera response lies from the true one, on copies made by `fipt degrade`.

Usage: python3 scripts/response_error.py FIPT COPY [COPY ...]

FIPT: the `fipt` binary; COPY: a folder `fipt degrade` wrote (its degrade.json holds the tone
curve as a table, a gamma, or "srgb"). Runs `FIPT info COPY --json` (the response fit of `fipt run`'s
load stage, without the light transport's contrast) and prints, per copy, the RMS of the
reported table (linear values at stored 0, 8, ..., 255) against the true curve after one
least-squares scale (a response is known only up to one):
- over all 33 values;
- over stored 0 ... 247, the values a run decodes (it counts 250 and above as clipped, and no
  photo tells where a curve ends above its clip).
A copy whose fit kept sRGB is scored with sRGB's curve.
"""
import json, subprocess, sys
import numpy as np

if len(sys.argv) < 3:
    sys.exit(__doc__)
fipt, copies = sys.argv[1], sys.argv[2:]


def srgb(s):
    return np.where(s <= 0.04045, s / 12.92, ((s + 0.055) / 1.055) ** 2.4)


def scaled_rms(fit, true):
    k = np.dot(fit, true) / np.dot(fit, fit)
    return np.sqrt(np.mean((k * fit - true) ** 2))


stored = np.linspace(0.0, 1.0, 33)
decoded = stored <= 250 / 255
print('copy outcome rms_all rms_0_247')
for c in copies:
    tone = json.load(open(f'{c}/degrade.json'))['request']['tone']
    info = json.loads(subprocess.run([fipt, 'info', c, '--json'], capture_output=True,
                                     text=True, check=True).stdout)
    fit = np.array((info.get('response') or {}).get('linear') or [])
    outcome = 'fitted' if len(fit) else 'srgb'
    if not len(fit):
        fit = srgb(stored)
    if isinstance(tone, dict) and 'gamma' in tone:
        true = stored ** tone['gamma']
    elif isinstance(tone, dict):
        table = np.array(tone['table'])
        true = np.interp(stored, np.linspace(0.0, 1.0, len(table)), table)
    else:
        true = srgb(stored)
    print(f'{c} {outcome} {scaled_rms(fit, true):.4f} '
          f'{scaled_rms(fit[decoded], true[decoded]):.4f}')
