"""Errors of dirac and ngspice at the same step against a fine ngspice reference (TSTEP/20).

Usage: python3 scripts/compare_ngspice.py [netlist ...]   (default: every bundled netlist with .tran)

For each netlist: ngspice runs a copy with `.options method=trap` and TMAX = TSTEP (its own time
points, compared with the reference at those points) and with TSTEP/20 (the reference); dirac runs
the netlist with --method midpoint, trapezoid and gauss2 (rows at t_k = k*TSTEP, compared with the
reference interpolated linearly onto them). Prints one markdown row per signal: max |error| of
ngspice and of each dirac method, and each method's ratio to ngspice. Needs numpy and ngspice.
"""
import subprocess, sys, os, re, csv, math, tempfile
import numpy as np

DIRAC = os.environ.get("DIRAC", os.path.join(os.path.dirname(__file__), "..", "target", "release", "dirac"))

def parse_raw(path):
    text = open(path, errors="replace").read()
    names = []
    lines = text.splitlines()
    i = 0
    nvars = npts = 0
    while i < len(lines):
        l = lines[i]
        if l.startswith("No. Variables:"): nvars = int(l.split(":")[1])
        if l.startswith("No. Points:"): npts = int(l.split(":")[1])
        if l.startswith("Variables:"):
            for k in range(nvars):
                parts = lines[i + 1 + k].split()
                names.append(parts[1].lower())
            i += nvars
        if l.startswith("Values:"):
            i += 1
            break
        i += 1
    vals = []
    tokens = " ".join(lines[i:]).split()
    # each point: index then nvars values
    k = 0
    data = np.zeros((npts, nvars))
    for p in range(npts):
        k += 1  # index
        for v in range(nvars):
            data[p, v] = float(tokens[k].split(",")[0]); k += 1
    return names, data

def ngspice(netlist, step, tmax, extra_opts=""):
    text = open(netlist).read()
    lines = text.splitlines()
    out = []
    for l in lines:
        m = re.match(r"\s*\.tran\s+(\S+)\s+(\S+)(.*)", l, re.I)
        if m:
            rest = m.group(3)
            uic = "uic" in rest.lower()
            l = f".tran {step} {m.group(2)} 0 {tmax}" + (" uic" if uic else "")
        if l.strip().lower() == ".end":
            continue
        out.append(l)
    out.append(f".options method=trap {extra_opts}")
    out.append(".end")
    d = tempfile.mkdtemp()
    deck = os.path.join(d, "deck.cir"); raw = os.path.join(d, "out.raw")
    open(deck, "w").write("\n".join(out) + "\n")
    env = dict(os.environ, SPICE_ASCIIRAWFILE="1")
    subprocess.run(["ngspice", "-b", "-r", raw, deck], capture_output=True, env=env, check=True)
    return parse_raw(raw)

def dirac(netlist, method="midpoint", h=None):
    cmd = [DIRAC, "run", netlist, "--quiet", "--method", method]
    if h: cmd += ["--h", str(h)]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError(p.stderr)
    rows = list(csv.reader(p.stdout.splitlines()))
    return rows[0], np.array([[float(x) for x in r] for r in rows[1:]])

def column(names, data, signal):
    # dirac v(x) ↔ ngspice v(x); i(v1) ↔ i(v1) / v1#branch; q(c) skipped
    s = signal.lower()
    for cand in [s, s.replace("i(", "").replace(")", "") + "#branch"]:
        if cand in names: return data[:, names.index(cand)]
    return None

def tran_step(netlist):
    for l in open(netlist):
        m = re.match(r"\s*\.tran\s+(\S+)", l, re.I)
        if m:
            return spice_number(m.group(1))
    return None

def spice_number(text):
    m = re.match(r"([-+0-9.eE]+)(meg|[fpnumkgt])?", text.lower())
    scale = {"f": 1e-15, "p": 1e-12, "n": 1e-9, "u": 1e-6, "m": 1e-3, "k": 1e3, "meg": 1e6, "g": 1e9, "t": 1e12}
    return float(m.group(1)) * scale.get(m.group(2), 1.0)

def breakpoints(netlist, tstop):
    """Corners of the netlist's PULSE, PWL and delayed SIN sources (where a linear interpolation
    of the reference is biased): rows within 2 steps of one are left out, as are the first 3."""
    out = []
    text = "\n".join(l for l in open(netlist).read().lower().splitlines()[1:]
                     if not l.lstrip().startswith("*"))
    for m in re.finditer(r"pulse\s*\(([^)]*)\)", text):
        a = [spice_number(x) for x in re.split(r"[\s,]+", m.group(1).strip())]
        a += [0.0] * (7 - len(a))
        td, tr, tf, pw, per = a[2], a[3], a[4], a[5], a[6] if a[6] > 0 else tstop
        t = td
        while t <= tstop:
            out += [t, t + tr, t + tr + pw, t + tr + pw + tf]
            t += per
    for m in re.finditer(r"pwl\s*\(([^)]*)\)", text):
        a = [spice_number(x) for x in re.split(r"[\s,]+", m.group(1).strip())]
        out += a[0::2]
    for m in re.finditer(r"sin[e]?\s*\(([^)]*)\)", text):
        a = [spice_number(x) for x in re.split(r"[\s,]+", m.group(1).strip())]
        if len(a) > 3:
            out.append(a[3])
    return out

def compare(netlist, tstep, methods=("midpoint", "gauss2")):
    ref_n, ref = ngspice(netlist, tstep / 20, tstep / 20)
    spi_n, spi = ngspice(netlist, tstep, tstep)
    tr = ref[:, 0]; ts = spi[:, 0]
    print(f"| **{os.path.basename(netlist)}** (h = {tstep:g}; ngspice: {len(ts)} points at h) | | | |")
    results = {}
    for method in methods:
        header, d = dirac(netlist, method)
        corners = breakpoints(netlist, d[-1, 0])
        keep = (d[:, 0] >= 3 * tstep) & np.all(
            [np.abs(d[:, 0] - b) > 2 * tstep for b in corners] or [np.ones(len(d), bool)], axis=0)
        d = d[keep]
        t = d[:, 0]
        for j, name in enumerate(header[1:], start=1):
            rc = column(ref_n, ref, name)
            sc = column(spi_n, spi, name)
            if rc is None or sc is None: continue
            if name.startswith("i("):
                pass
            refk = np.interp(t, tr, rc)
            err_d = np.max(np.abs(d[:, j] - refk))
            # ngspice at h, at its own points (compare against the reference there)
            keep_s = (ts >= 3 * tstep) & np.all(
                [np.abs(ts - b) > 2 * tstep for b in corners] or [np.ones(len(ts), bool)], axis=0)
            err_s = np.max(np.abs(sc - np.interp(ts, tr, rc))[keep_s])
            results.setdefault(name, {})[method] = err_d
            results[name]["ngspice"] = err_s
    for name, r in results.items():
        ratio = lambda m: f"({r[m] / r['ngspice']:.2f}x)" if r["ngspice"] > 1e-12 else "(round-off)"
        cells = [f"{r['ngspice']:.2e}"] + [f"{r[m]:.2e} {ratio(m)}" for m in methods]
        print(f"| {name} | " + " | ".join(cells) + " |")

if __name__ == "__main__":
    files = sys.argv[1:] or sorted(
        os.path.join(os.path.dirname(__file__), "..", "examples", "netlists", f)
        for f in os.listdir(os.path.join(os.path.dirname(__file__), "..", "examples", "netlists"))
        if f.endswith(".cir"))
    print("| signal | ngspice (trap) | dirac midpoint | dirac gauss2 |")
    print("|---|---|---|---|")
    for f in files:
        h = tran_step(f)
        if h is not None:
            compare(f, h)
