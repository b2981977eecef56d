#!/usr/bin/env python3
"""Charts and equal-error ratios of `mbfmu bench` and benches/peers.py.

    python benches/plot.py [--out docs/bench]

Reads DIR/results.csv, reference.csv, longrun.csv, invariant.csv, springy_rigid*.csv (from
`mbfmu bench`) and peers.csv, peers_longrun.csv, peers_invariant.csv (from peers.py), writes:

- wp_<System>.png, one per system, a row per scene: error at the stop time vs CPU time (left)
  and vs RHS evaluations (right), log-log. Ours: adaptive methods in one doStep over the scene
  (solid: the integrator alone, as the peers run), fixed-step methods on the 0.01 s grid
  (dashed), DOPRI5 on the 0.01 s grid (dotted: the FMU as a co-simulation master drives it);
  peers dash-dot (scipy squares, CVODE triangles). Grey band: below the reference's
  estimated error, where differences mean nothing. Failed runs are not drawn (results.csv
  keeps them).
- invariant_<System>.png, for the systems with conservative scenes, a row per such scene:
  |E(t) - E(0)| / |E(0)| against simulated time over the long run (left, log-log; adaptive
  methods and peers at tolerance 1e-8, fixed-step methods at their largest step that ran),
  and its maximum over the run against RHS evaluations, every setting (right).
- springy_rigid.png: the springy pendulum's stiff scene against the rigid pendulum.
- ratios.csv: per scene and error target, the cost of our best method, of the best CVODE
  method and of the best scipy method at equal error (log-log interpolation between the two
  runs around the target), and their ratios; printed as a per-class summary.
"""

import argparse
import csv
import math
import os
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

OURS = ["RK4", "DOPRI5", "ExplicitEuler", "SymplecticEuler", "Verlet", "ImplicitMidpoint",
        "Gauss4", "Gauss6", "DOP853", "RADAU5", "ExactLinear"]
# The exact propagator e^{Ah} of the linear scenes is drawn (the floor) but is no integrator:
# it is left out of "our best method" in the equal-error ratios.
NOT_COMPARED = {"ExactLinear"}
ADAPTIVE = {"DOPRI5", "DOP853", "RADAU5"}
PEERS = ["scipy RK45", "scipy DOP853", "scipy Radau", "scipy BDF", "scipy LSODA",
         "CVODE-Adams", "CVODE-BDF"]
# Ours: tab10; peers: darker, distinct hues (and their own markers and dash-dot lines).
COLOR = {m: plt.get_cmap("tab10")(i) for i, m in enumerate(OURS[:10])}
COLOR["ExactLinear"] = "#4b0082"
COLOR.update(zip(PEERS, ["#556b2f", "#8b0000", "#ff00ff", "#00008b", "#daa520", "#000000", "#2e8b57"]))
COLOR["DOPRI5 (grid 0.01)"] = COLOR["DOPRI5"]

# Scene classes of the equal-error summary.
STIFF = {("TwoMassChain", "stiff"), ("SpringyPendulum", "stiff")}
# Polynomial solutions (constant accelerations): every method is exact at its loosest setting,
# so the counts measure start-up costs, not accuracy. Kept in ratios.csv, not in the summary.
TRIVIAL = {("RollingHoop", "roll"), ("RollingDisk", "straight"), ("RollingDisk", "driven"),
           ("Projectile", "throw")}
TARGETS = (1e-5, 1e-9)          # state error at the stop time
LONG_TARGETS = (1e-6, 1e-9)     # max invariant error over a long run


def read(path):
    if not os.path.exists(path):
        return []
    with open(path) as f:
        return list(csv.DictReader(f))


def fnum(s):
    try:
        return float(s)
    except (TypeError, ValueError):
        return float("nan")


def peer_label(r):
    return ("scipy " if r["solver"] == "scipy" else "") + r["method"]


def style_of(label):
    if label.startswith("scipy"):
        return dict(ls="-.", marker="s", ms=3, lw=1)
    if label.startswith("CVODE"):
        return dict(ls="-.", marker="^", ms=4, lw=1.2)
    if label.endswith("(grid 0.01)"):
        return dict(ls=":", marker="o", ms=2, lw=1)
    if label in ADAPTIVE:
        return dict(ls="-", marker="o", ms=3, lw=1.5)
    return dict(ls="--", marker=".", ms=4, lw=1)


def curves(results, peers, system, scene):
    """{label: [(cpu, rhs, err)]} of one scene."""
    out = defaultdict(list)
    for r in results:
        if r["system"] != system or r["scene"] != scene or r["status"] != "ok":
            continue
        free = r["setting_kind"] == "tol" and fnum(r["comm_step"]) > 0.011
        if r["setting_kind"] == "tol" and not free:
            if r["method"] != "DOPRI5":
                continue
            label = "DOPRI5 (grid 0.01)"
        else:
            label = r["method"]
        out[label].append((fnum(r["cpu_s"]), fnum(r["rhs_evals"]), fnum(r["error_final"])))
    for r in peers:
        if r["system"] != system or r["scene"] != scene or r["status"] != "ok":
            continue
        out[peer_label(r)].append((fnum(r["cpu_s"]), fnum(r["rhs_evals"]), fnum(r["error_final"])))
    return out


def legend_handles(labels):
    return [Line2D([], [], color=COLOR.get(lb, "k"), label=lb, **style_of(lb)) for lb in labels]


def ordered(labels):
    order = OURS + ["DOPRI5 (grid 0.01)"] + PEERS
    return sorted(labels, key=lambda lb: order.index(lb) if lb in order else 99)


def work_precision(results, peers, reference, outdir):
    written = []
    scenes = defaultdict(list)
    for r in results:
        if r["scene"] not in scenes[r["system"]]:
            scenes[r["system"]].append(r["scene"])
    ref_error = {(r["system"], r["scene"]): fnum(r["ref_error"]) for r in reference}
    skipped = {(r["system"], r["scene"]): r["message"] for r in peers
               if r["status"] == "skipped" and r["solver"] == "-"}
    for system, names in scenes.items():
        fig, axes = plt.subplots(len(names), 2, figsize=(12, 3.1 * len(names) + 1.2), squeeze=False)
        used = set()
        for row, scene in enumerate(names):
            data = curves(results, peers, system, scene)
            for col, (k, xlabel) in enumerate(((0, "CPU time [s] (min of repeats)"),
                                               (1, "RHS evaluations"))):
                ax = axes[row][col]
                for label in ordered(data):
                    pts = sorted(p for p in data[label] if p[2] > 0 and p[k] > 0)
                    if not pts:
                        continue
                    used.add(label)
                    ax.loglog([p[k] for p in pts], [p[2] for p in pts], color=COLOR.get(label, "k"),
                              **style_of(label))
                floor = ref_error.get((system, scene), float("nan"))
                if floor > 0:
                    ax.axhspan(1e-17, floor, color="0.85", zorder=0)
                ax.set_ylim(1e-15, 1e2)
                ax.grid(True, which="major", alpha=0.3)
                ax.set_xlabel(xlabel, fontsize=8)
                ax.set_ylabel("scaled error at stop time", fontsize=8)
                ax.tick_params(labelsize=7)
                title = f"{system}/{scene}"
                if (system, scene) in skipped:
                    title += "  (peers skipped: event)"
                ax.set_title(title, fontsize=9)
        fig.legend(handles=legend_handles(ordered(used)), loc="upper center", ncol=6, fontsize=7,
                   frameon=False)
        fig.tight_layout(rect=(0, 0, 1, 1 - 0.9 / (3.1 * len(names) + 1.2)))
        path = os.path.join(outdir, f"wp_{system}.png")
        fig.savefig(path, dpi=72)
        plt.close(fig)
        written.append(path)
    return written


def invariant_charts(longrun, invariant, peers_long, peers_inv, outdir):
    written = []
    by_system = defaultdict(list)
    for r in longrun:
        if r["scene"] not in by_system[r["system"]]:
            by_system[r["system"]].append(r["scene"])
    hist = defaultdict(list)
    for r in invariant:
        hist[(r["system"], r["scene"], r["method"], fnum(r["setting"]))].append(
            (fnum(r["t"]), fnum(r["invariant_error"])))
    for r in peers_inv:
        hist[(r["system"], r["scene"], peer_label(r), fnum(r["tol"]))].append(
            (fnum(r["t"]), fnum(r["invariant_error"])))
    for system, names in by_system.items():
        fig, axes = plt.subplots(len(names), 2, figsize=(12, 3.1 * len(names) + 1.2), squeeze=False)
        used = set()
        for row, scene in enumerate(names):
            ax, ax2 = axes[row]
            mine = [r for r in longrun if r["system"] == system and r["scene"] == scene]
            theirs = [r for r in peers_long if r["system"] == system and r["scene"] == scene]
            horizon = fnum(mine[0]["horizon"]) if mine else float("nan")
            chosen = {}
            for r in mine:
                if r["status"] != "ok":
                    continue
                m, s = r["method"], fnum(r["setting"])
                if m in ADAPTIVE:
                    if abs(s - 1e-8) < 1e-20:
                        chosen[m] = (m, s, f"{m} tol 1e-8")
                elif m not in chosen or s > chosen[m][1]:
                    chosen[m] = (m, s, f"{m} h {s:g}")
            for r in theirs:
                if r["status"] == "ok" and abs(fnum(r["tol"]) - 1e-8) < 1e-20:
                    lb = peer_label(r)
                    chosen[lb] = (lb, 1e-8, f"{lb} tol 1e-8")
            for label in ordered(chosen):
                key, s, _ = chosen[label]
                pts = sorted(hist.get((system, scene, key, s), []))
                pts = [(t, max(e, 1e-17)) for t, e in pts if t > 0]
                if pts:
                    used.add(label)
                    ax.loglog([p[0] for p in pts], [p[1] for p in pts], color=COLOR.get(label, "k"),
                              ls=style_of(label)["ls"], lw=1.2)
            hs = sorted({chosen[m][1] for m in chosen if m in OURS and m not in ADAPTIVE}, reverse=True)
            h_text = ("h " + "/".join(f"{h:g}" for h in hs) if len(hs) > 1 else f"h = {hs[0]:g}") if hs else ""
            ax.set_title(f"{system}/{scene}: invariant error over {horizon:g} s "
                         f"(tolerance 1e-8, fixed steps {h_text})", fontsize=8)
            ax.set_xlabel("simulated time [s]", fontsize=8)
            ax.set_ylabel("|E(t) - E(0)| / |E(0)|", fontsize=8)
            ax.set_ylim(1e-17, 1e1)
            ax.grid(True, which="major", alpha=0.3)
            ax.tick_params(labelsize=7)
            curves2 = defaultdict(list)
            for r in mine:
                if r["status"] == "ok":
                    curves2[r["method"]].append((fnum(r["rhs_evals"]), fnum(r["max_invariant_error"])))
            for r in theirs:
                if r["status"] == "ok":
                    curves2[peer_label(r)].append((fnum(r["rhs_evals"]), fnum(r["max_invariant_error"])))
            for label in ordered(curves2):
                pts = sorted((n, max(e, 1e-17)) for n, e in curves2[label] if n > 0)
                if pts:
                    used.add(label)
                    ax2.loglog([p[0] for p in pts], [p[1] for p in pts], color=COLOR.get(label, "k"),
                               **style_of(label))
            ax2.set_title(f"{system}/{scene}: max invariant error over {horizon:g} s vs work",
                          fontsize=8)
            ax2.set_xlabel("RHS evaluations over the long run", fontsize=8)
            ax2.set_ylabel("max |E(t) - E(0)| / |E(0)|", fontsize=8)
            ax2.set_ylim(1e-17, 1e1)
            ax2.grid(True, which="major", alpha=0.3)
            ax2.tick_params(labelsize=7)
        fig.legend(handles=legend_handles(ordered(used)), loc="upper center", ncol=6, fontsize=7,
                   frameon=False)
        fig.tight_layout(rect=(0, 0, 1, 1 - 0.9 / (3.1 * len(names) + 1.2)))
        path = os.path.join(outdir, f"invariant_{system}.png")
        fig.savefig(path, dpi=72)
        plt.close(fig)
        written.append(path)
    return written


# ---------------------------------------------------------------------------------------
# Equal-error costs
# ---------------------------------------------------------------------------------------

def cost_at(pts, target, k):
    """Cost (index k of the point) to reach error <= target on one curve [(cpu, rhs, err)].

    Runs in the order of their RHS counts (noise-free, it follows the tolerance or step:
    ordering by measured time would let timing noise reorder them; equal counts, larger error
    first); the first that meets the
    target and the one before it are interpolated log-log. Returns (cost, exact): exact
    False when the first run already meets the target (its cost is an upper bound); None when
    no run reaches the target."""
    pts = sorted((p for p in pts if p[2] > 0 and p[k] > 0), key=lambda p: (p[1], -p[2]))
    for j, p in enumerate(pts):
        if p[2] <= target:
            if j == 0:
                return p[k], False
            a = pts[j - 1]
            if a[2] <= p[2]:
                return p[k], True
            w = (math.log(a[2]) - math.log(target)) / (math.log(a[2]) - math.log(p[2]))
            return math.exp((1 - w) * math.log(a[k]) + w * math.log(p[k])), True
    return None


def best(data, labels, target, k):
    """(cost, exact, label) of the cheapest of `labels` at the target."""
    found = []
    for lb in labels:
        if lb in data:
            c = cost_at(data[lb], target, k)
            if c:
                found.append((c[0], c[1], lb))
    return min(found) if found else None


def ours_labels(data):
    return [lb for lb in data if lb in OURS and lb not in NOT_COMPARED]


def cvode_labels(data):
    return [lb for lb in data if lb.startswith("CVODE")]


def scipy_labels(data):
    return [lb for lb in data if lb.startswith("scipy")]


def ratio_rows(results, peers, reference, longrun, peers_long):
    rows = []
    ref_error = {(r["system"], r["scene"]): fnum(r["ref_error"]) for r in reference}
    call = {}
    for r in peers:
        if r["solver"] == "cvode" and r["rhs_call_s"]:
            call[(r["system"], r["scene"])] = (fnum(r["rhs_call_s"]), fnum(r["jac_call_s"]))
    cvode_runs = defaultdict(list)  # (system, scene, label) -> [(cpu, rhs, err, jac)]
    for r in peers:
        if r["solver"] == "cvode" and r["status"] == "ok":
            cvode_runs[(r["system"], r["scene"], r["method"])].append(
                (fnum(r["cpu_s"]), fnum(r["rhs_evals"]), fnum(r["error_final"]), fnum(r["jac_evals"])))
    scenes = []
    for r in results:
        if (r["system"], r["scene"]) not in scenes:
            scenes.append((r["system"], r["scene"]))
    for system, scene in scenes:
        data = curves(results, peers, system, scene)
        if not cvode_labels(data) and not scipy_labels(data):
            continue
        klass = ("stiff" if (system, scene) in STIFF else
                 "trivial" if (system, scene) in TRIVIAL else "non-stiff smooth")
        for target in TARGETS:
            floor = ref_error.get((system, scene), float("nan"))
            row = dict(class_=klass, system=system, scene=scene, measure="error_final",
                       target=f"{target:g}", ref_error=f"{floor:.1e}")
            if not floor <= target / 10:
                row["note"] = "reference not accurate enough for this target"
                rows.append(row)
                continue
            fill(row, data, target)
            # CVODE's time without its FMI calls (what it would take if f and J were free).
            if row.get("cvode_cpu_method") and (system, scene) in call:
                f_s, j_s = call[(system, scene)]
                own = [(c - n * f_s - jv * j_s, n, e) for c, n, e, jv in
                       cvode_runs[(system, scene, row["cvode_cpu_method"])]]
                c = cost_at([p for p in own if p[0] > 0], target, 0)
                if c and c[1]:
                    row["cvode_own_cpu"] = f"{c[0]:.3e}"
                    row["cpu_ratio_vs_cvode_own"] = f"{fnum(row['ours_cpu']) / c[0]:.3g}"
            rows.append(row)
    # Long runs of the conservative scenes: error = max invariant error over the horizon.
    keys = []
    for r in longrun:
        if (r["system"], r["scene"]) not in keys:
            keys.append((r["system"], r["scene"]))
    for system, scene in keys:
        data = defaultdict(list)
        for r in longrun:
            if r["system"] == system and r["scene"] == scene and r["status"] == "ok":
                data[r["method"]].append((fnum(r["cpu_s"]), fnum(r["rhs_evals"]),
                                          fnum(r["max_invariant_error"])))
        for r in peers_long:
            if r["system"] == system and r["scene"] == scene and r["status"] == "ok":
                data[peer_label(r)].append((fnum(r["cpu_s"]), fnum(r["rhs_evals"]),
                                            fnum(r["max_invariant_error"])))
        if not cvode_labels(data) and not scipy_labels(data):
            continue
        horizon = next(fnum(r["horizon"]) for r in longrun if r["system"] == system and r["scene"] == scene)
        for target in LONG_TARGETS:
            klass = "trivial" if (system, scene) in TRIVIAL else "conservative long run"
            row = dict(class_=klass, system=system, scene=scene,
                       measure=f"max invariant error over {horizon:g} s", target=f"{target:g}")
            fill(row, data, target)
            rows.append(row)
    return rows


def fill(row, data, target):
    for k, unit in ((1, "rhs"), (0, "cpu")):
        o = best(data, ours_labels(data), target, k)
        if not o:
            continue
        row[f"ours_{unit}"] = f"{o[0]:.4g}" if k else f"{o[0]:.3e}"
        row[f"ours_{unit}_method"] = o[2] + ("" if o[1] else " (<=)")
        for name, labels in (("cvode", cvode_labels(data)), ("scipy", scipy_labels(data))):
            p = best(data, labels, target, k)
            if not p:
                errs = [q[2] for lb in labels for q in data[lb] if q[2] > 0]
                if errs:
                    row[f"{name}_{unit}_method"] = f"not reached (smallest error {min(errs):.1e})"
                continue
            row[f"{name}_{unit}"] = f"{p[0]:.4g}" if k else f"{p[0]:.3e}"
            row[f"{name}_{unit}_method"] = p[2] + ("" if p[1] else " (<=)")
            if p[1]:  # a peer's upper bound would flatter us: no ratio then
                row[f"{unit}_ratio_vs_{name}"] = f"{o[0] / p[0]:.3g}"


RATIO_FIELDS = ["class_", "system", "scene", "measure", "target", "ref_error",
                "ours_rhs", "ours_rhs_method", "cvode_rhs", "cvode_rhs_method",
                "scipy_rhs", "scipy_rhs_method", "rhs_ratio_vs_cvode", "rhs_ratio_vs_scipy",
                "ours_cpu", "ours_cpu_method", "cvode_cpu", "cvode_cpu_method",
                "scipy_cpu", "scipy_cpu_method", "cpu_ratio_vs_cvode", "cpu_ratio_vs_scipy",
                "cvode_own_cpu", "cpu_ratio_vs_cvode_own", "note"]


def geo(values):
    v = [x for x in values if x > 0]
    if not v:
        return None
    return math.exp(sum(map(math.log, v)) / len(v)), min(v), max(v), len(v)


def summary(rows):
    lines = []
    groups = defaultdict(list)
    for r in rows:
        groups[(r["class_"], r["target"])].append(r)
    for (klass, target), rs in sorted(groups.items()):
        if klass == "trivial":
            continue
        parts = []
        for col in ("rhs_ratio_vs_cvode", "cpu_ratio_vs_cvode", "cpu_ratio_vs_cvode_own",
                    "rhs_ratio_vs_scipy", "cpu_ratio_vs_scipy"):
            g = geo([fnum(r.get(col)) for r in rs if r.get(col)])
            if g:
                parts.append(f"  {col:<24} {g[0]:.2g}  [{g[1]:.2g}, {g[2]:.2g}]  (n = {g[3]})")
        missing = [f"{r['system']}/{r['scene']}" for r in rs if not r.get("rhs_ratio_vs_cvode")]
        lines.append(f"{klass}, error target {target} ({len(rs)} scenes; no CVODE ratio for: "
                     f"{', '.join(missing) or 'none'}):")
        lines += parts
    return lines


def abi_check(results, peers):
    """Our adaptive methods through the .so's C ABI (peers.csv, solver mbfmu-so) against the
    same runs in-process (results.csv): time ratios and the largest error difference."""
    mine = {}
    for r in results:
        if r["status"] == "ok" and r["setting_kind"] == "tol" and fnum(r["comm_step"]) > 0.011:
            mine[(r["system"], r["scene"], r["method"], fnum(r["setting"]))] = r
    ratios, diffs = [], []
    for r in peers:
        if r["solver"] != "mbfmu-so" or r["status"] != "ok":
            continue
        m = mine.get((r["system"], r["scene"], r["method"], fnum(r["tol"])))
        if not m:
            continue
        ratios.append(fnum(r["cpu_s"]) / fnum(m["cpu_s"]))
        a, b = fnum(r["error_final"]), fnum(m["error_final"])
        diffs.append(abs(a - b) / max(abs(b), 1e-300))
    if not ratios:
        return []
    ratios.sort()
    return [f"our adaptive methods through the FMU's C ABI vs in-process ({len(ratios)} runs): time "
            f"ratio median {ratios[len(ratios) // 2]:.2f}, quartiles {ratios[len(ratios) // 4]:.2f} .. "
            f"{ratios[3 * len(ratios) // 4]:.2f}; largest relative difference of the errors "
            f"{max(diffs):.1e}"]


# ---------------------------------------------------------------------------------------
# Springy vs rigid
# ---------------------------------------------------------------------------------------

def springy_rigid(outdir):
    traj = read(os.path.join(outdir, "springy_rigid.csv"))
    cost = read(os.path.join(outdir, "springy_rigid_cost.csv"))
    stiff = read(os.path.join(outdir, "springy_rigid_stiffness.csv"))
    if not traj:
        return [], []
    fig, axes = plt.subplots(2, 2, figsize=(12, 8))
    t = [fnum(r["t"]) for r in traj]
    ax = axes[0][0]
    ax.plot(t, [fnum(r["theta_springy"]) for r in traj], label="θ springy (c = 1e6 N/m)", lw=2)
    ax.plot(t, [fnum(r["theta_rigid"]) for r in traj], "--", label="θ rigid (l = r_eq, I_O = m r_eq²)")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("θ [rad]")
    ax.legend(fontsize=8)
    ax.set_title("SpringyPendulum/stiff and its rigid pendulum: θ(t)", fontsize=9)
    ax = axes[0][1]
    ax.plot(t, [fnum(r["dtheta"]) for r in traj], label="θ_springy − θ_rigid [rad]")
    ax.plot(t, [fnum(r["stretch"]) for r in traj], lw=0.6, label="r − r_eq [m] (spring's extra stretch)")
    ax.set_xlabel("t [s]")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    ax.set_title("difference of the trajectories (references, DOP853 at 1e-13)", fontsize=9)
    ax = axes[1][0]
    rows_out = []
    for model, ls in (("springy", "-"), ("rigid", "--")):
        data = defaultdict(list)
        for r in cost:
            if r["model"] == model and r["status"] == "ok":
                data[r["method"]].append((fnum(r["cpu_s"]), fnum(r["rhs_evals"]), fnum(r["error_final"])))
        for label in ordered(data):
            pts = sorted(p for p in data[label] if p[2] > 0)
            if pts and label in ("DOP853", "RADAU5", "Gauss6", "RK4"):
                ax.loglog([p[1] for p in pts], [p[2] for p in pts], ls=ls, marker="o", ms=2,
                          color=COLOR[label], label=f"{label} ({model})")
        for target in (1e-4, 1e-6, 1e-8):
            for k, unit in ((1, "rhs"), (0, "cpu")):
                b = best(data, ours_labels(data), target, k)
                if b:
                    rows_out.append(dict(model=model, target=target, unit=unit, cost=b[0],
                                         method=b[2], exact=b[1]))
    ax.set_xlabel("RHS evaluations")
    ax.set_ylabel("error in (θ, θ̇) at t = 2 s")
    ax.set_ylim(1e-14, 1e1)
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize=6, ncol=2)
    ax.set_title("cost against accuracy in the shared coordinates (solid springy, dashed rigid)",
                 fontsize=9)
    ax = axes[1][1]
    if stiff:
        c = [fnum(r["c"]) for r in stiff]
        ax.loglog(c, [fnum(r["max_abs_dtheta"]) for r in stiff], "o-", label="max |Δθ| over 2 s [rad]")
        ax.set_xlabel("spring stiffness c [N/m]")
        ax.set_ylabel("max |θ_springy − θ_rigid| [rad]")
        ax2 = ax.twinx()
        for col, lb, ls in (("rhs_springy_DOP853", "RHS springy DOP853 1e-8", "-"),
                            ("rhs_rigid_DOP853", "RHS rigid DOP853 1e-8", "--"),
                            ("rhs_springy_RADAU5", "RHS springy RADAU5 1e-8", "-"),
                            ("rhs_rigid_RADAU5", "RHS rigid RADAU5 1e-8", "--")):
            ax2.loglog(c, [fnum(r[col]) for r in stiff], ls=ls, marker=".",
                       color=COLOR["DOP853" if "DOP853" in col else "RADAU5"], label=lb)
        ax2.set_ylabel("RHS evaluations over 2 s")
        h1, l1 = ax.get_legend_handles_labels()
        h2, l2 = ax2.get_legend_handles_labels()
        ax.legend(h1 + h2, l1 + l2, fontsize=7, loc="lower left")
        ax.grid(True, which="major", alpha=0.3)
        ax.set_title("model difference falls as 1/c, the springy model's cost grows", fontsize=9)
    fig.tight_layout()
    path = os.path.join(outdir, "springy_rigid.png")
    fig.savefig(path, dpi=72)
    plt.close(fig)
    return [path], rows_out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.path.join(ROOT, "docs", "bench"))
    args = ap.parse_args()
    d = args.out
    results = read(os.path.join(d, "results.csv"))
    peers = read(os.path.join(d, "peers.csv"))
    reference = read(os.path.join(d, "reference.csv"))
    longrun = read(os.path.join(d, "longrun.csv"))
    peers_long = read(os.path.join(d, "peers_longrun.csv"))
    written = work_precision(results, peers, reference, d)
    written += invariant_charts(longrun, read(os.path.join(d, "invariant.csv")), peers_long,
                                read(os.path.join(d, "peers_invariant.csv")), d)
    paths, springy = springy_rigid(d)
    written += paths
    rows = ratio_rows(results, peers, reference, longrun, peers_long)
    path = os.path.join(d, "ratios.csv")
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=RATIO_FIELDS, restval="")
        w.writeheader()
        w.writerows(rows)
    written.append(path)
    text = ["Equal-error ratios, ours / peer (< 1: ours cheaper); geometric mean [min, max] over "
            "the scenes of a class (from ratios.csv):"]
    text += summary(rows)
    text += [""] + abi_check(results, peers)
    if springy:
        text += ["", "Springy (stiff, c = 1e6) vs rigid pendulum, best of our methods at equal error "
                 "in (θ, θ̇) at t = 2 s:"]
        by = {(r["model"], r["target"], r["unit"]): r for r in springy}
        for target in (1e-4, 1e-6, 1e-8):
            for unit in ("rhs", "cpu"):
                a, b = by.get(("springy", target, unit)), by.get(("rigid", target, unit))
                if a and b:
                    fmt = "{:.0f}" if unit == "rhs" else "{:.2e} s"
                    text.append(
                        f"  target {target:g} {unit}: springy {fmt.format(a['cost'])} ({a['method']}"
                        f"{'' if a['exact'] else ', <='}), rigid {fmt.format(b['cost'])} ({b['method']}"
                        f"{'' if b['exact'] else ', <='}): ratio {a['cost'] / b['cost']:.3g}")
        traj = read(os.path.join(d, "springy_rigid.csv"))
        if traj:
            worst = max(traj, key=lambda r: abs(fnum(r["dtheta"])))
            text.append(f"  max |θ_springy − θ_rigid| over the scene: {abs(fnum(worst['dtheta'])):.2e} rad "
                        f"(t = {fnum(worst['t']):g} s); max |θ̇ difference| "
                        f"{max(abs(fnum(r['dtheta_dot'])) for r in traj):.2e} rad/s")
    path = os.path.join(d, "summary.txt")
    with open(path, "w") as f:
        f.write("\n".join(text) + "\n")
    written.append(path)
    for p in written:
        print("wrote", p)
    print()
    print("\n".join(text))


if __name__ == "__main__":
    main()
