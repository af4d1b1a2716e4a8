"""How far the front end actually drifts between two scans, against what the keyframe step's
covariance models claim (README, "A model of the front end's drift"; mapper/keyframe_step.rs).

Usage: chain_calibration.py COV_DIR OUT_DIR [good|cheap ...]   (PER_WORLD=1 for a line per world)

COV_DIR holds one WORLD.cov per generated world, written by an `evaluate WORLD --method
graph-open` run with docs/experiments/chain-calibration.diff applied and DBG_COV_FILE set
(one line per scan: stamp_ns x y heading, the scan's covariance xx xy yy θθ, the odometry's
share of it xx xy yy θθ); OUT_DIR is that run's --out (its truth.csv per world).
Per bin of route distance between scans i < j: the rms of the relative heading error
(estimate vs truth), and E[e²/V] for V = every scan's covariance summed (A, the model before
2026-12-07), the anchored model (B), and the measured headings summed (M, the model since).
"""
import sys, glob, os, math, bisect
import numpy as np

def wrap(a): return (a + math.pi) % (2*math.pi) - math.pi

def load(cov):
    d = np.loadtxt(cov)
    name = os.path.basename(cov)[:-4]  # gen-corridor-cheap-35
    parts = name.split('-'); short = f"{parts[0]}-{parts[1]}-{parts[3]}"
    tr = np.genfromtxt(f"{OUT_DIR}/{short}/graph-open/truth.csv", delimiter=',', names=True)
    tt = np.round(tr['t']*1e9).astype(np.int64)
    idx = {t: k for k, t in enumerate(tt)}
    rows = [k for k in range(len(d)) if int(d[k,0]) in idx]
    d = d[rows]; ti = [idx[int(s)] for s in d[:,0]]
    truth = np.stack([tr['x'][ti], tr['y'][ti], tr['theta'][ti]], 1)
    return name, d, truth

def series(f):
    """One world's scans: route (m), per-scan heading error vs the truth's, cumulative sums."""
    name, d, tr = load(f)
    w = {"name": name, "d": d, "tr": tr, "n": len(d)}
    w["route"] = np.concatenate([[0], np.cumsum(np.hypot(np.diff(tr[:,0]), np.diff(tr[:,1])))])
    w["meas"] = np.abs(d[:,7]-d[:,11]) > 1e-15          # ICP measured the heading
    w["cth"] = np.cumsum(d[:,7]); w["uth"] = np.cumsum(d[:,11])
    w["mth"] = np.cumsum(np.where(w["meas"], d[:,7], 0.0))
    w["cxy"] = np.cumsum(d[:,4]+d[:,6]); w["uxy"] = np.cumsum(d[:,8]+d[:,10])
    w["est_th"] = np.unwrap(d[:,3]); w["tru_th"] = np.unwrap(tr[:,2])
    return w

def pairs(w, step, bins):
    """(i, j, heading error e, measured-heading variance M) for scans j `b` m of route after i."""
    d, meas, mth = w["d"], w["meas"], w["mth"]
    for i in range(0, w["n"], step):
        for b in bins:
            j = bisect.bisect_left(w["route"], w["route"][i] + b)
            if j >= w["n"]: break
            e = wrap((w["est_th"][j]-w["est_th"][i]) - (w["tru_th"][j]-w["tru_th"][i]))
            M = mth[j]-mth[i] + (0 if meas[j] else d[j,11]) + (0 if meas[i] else d[i,11])
            yield b, i, j, e, M

def rel(p, a, c):
    """Pose c's position in pose a's frame."""
    dx, dy = p[c,0]-p[a,0], p[c,1]-p[a,1]; th = p[a,2]
    return np.array([math.cos(th)*dx+math.sin(th)*dy, -math.sin(th)*dx+math.cos(th)*dy])

BINS = [0.5, 1, 2, 4, 8, 16, 32, 64, 128]
def analyse(files, label):
    acc = {b: [] for b in BINS}
    for f in files:
        try:
            w = series(f)
        except FileNotFoundError:
            continue
        d, tr = w["d"], w["tr"]
        pe = np.array([d[:,1],d[:,2],d[:,3]]).T
        for b, i, j, e, M in pairs(w, 7, BINS):
            ep = rel(pe, i, j) - rel(tr, i, j)
            A = w["cth"][j]-w["cth"][i]; B = d[j,7] + (w["uth"][j]-w["uth"][i])
            Axy = w["cxy"][j]-w["cxy"][i]; Bxy = d[j,4]+d[j,6] + (w["uxy"][j]-w["uxy"][i])
            acc[b].append((e*e, A, B, j-i, ep@ep, Axy, Bxy, d[j,7], M))
    print(f"== {label} ({len(files)} worlds)")
    print(" route_m  pairs scans  rms_dθ°  sqrt(sumcov)°  sqrt(anch)°  sqrt(1scan)°  E[e²/A]  E[e²/B]   rms_dp m  sqrt(Axy)  sqrt(Bxy)  sqrt(M)° E[e²/M] med(e²/M)")
    for b in BINS:
        a = np.array(acc[b])
        if len(a) == 0: continue
        print(f"{b:7.1f} {len(a):6d} {a[:,3].mean():5.0f} {math.degrees(math.sqrt(a[:,0].mean())):8.3f} {math.degrees(math.sqrt(a[:,1].mean())):12.3f} {math.degrees(math.sqrt(a[:,2].mean())):12.3f} {math.degrees(math.sqrt(a[:,7].mean())):12.3f} {np.mean(a[:,0]/a[:,1]):8.2f} {np.mean(a[:,0]/a[:,2]):8.2f} {math.sqrt(a[:,4].mean()):9.3f} {math.sqrt(a[:,5].mean()):9.3f} {math.sqrt(a[:,6].mean()):9.3f} {math.degrees(math.sqrt(a[:,8].mean())):8.3f} {np.mean(a[:,0]/a[:,8]):7.2f} {np.median(a[:,0]/a[:,8]):7.2f}")

def per_world(files):
    print("world                      rms_dθ°@16-64m  E[e²/A]  E[e²/M]  p95(e²/M)  frac_unmeasured")
    for f in files:
        try:
            w = series(f)
        except FileNotFoundError:
            continue
        r = [(e*e, e*e/(w["cth"][j]-w["cth"][i]), e*e/M) for _, i, j, e, M in pairs(w, 5, (16, 32, 64))]
        r = np.array(r)
        if len(r)==0: continue
        print(f"{w['name']:26s} {math.degrees(math.sqrt(r[:,0].mean())):8.3f} {r[:,1].mean():9.2f} {r[:,2].mean():8.2f} {np.percentile(r[:,2],95):9.2f} {1-w['meas'].mean():8.2f}")

COV_DIR, OUT_DIR = sys.argv[1], sys.argv[2]
files = sorted(glob.glob(f"{COV_DIR}/*.cov"))
for g in sys.argv[3:] or ["good", "cheap"]:
    analyse([f for f in files if f"-{g}-" in f], g)
if os.environ.get("PER_WORLD"):
    per_world(files)
