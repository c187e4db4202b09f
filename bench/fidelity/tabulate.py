#!/usr/bin/env python3
"""Tables and a figure of bench/fidelity/fidelity's results (docs/algorithms.md §12.3).

Usage: tabulate.py OUT "WORLDS" "PROFILES" CALIBRATION_WORLD
Reads OUT/<world>-<profile>.csv (kestrel-fidelity --csv) and OUT/<world>-<profile>.cal.txt
(kestrel-calibrate's tables); writes OUT/table.md, OUT/calibration.md, OUT/mount.md and
OUT/fidelity.png.
"""
import csv
import os
import re
import sys

out, worlds, profiles, cal_world = sys.argv[1], sys.argv[2].split(), sys.argv[3].split(), sys.argv[4]

rows = []
for p in profiles:
    for w in worlds:
        path = os.path.join(out, "%s-%s.csv" % (w, p))
        if not os.path.exists(path):
            print("tabulate: no %s" % path, file=sys.stderr)
            continue
        with open(path) as f:
            for r in csv.DictReader(f):
                r["world"], r["profile"] = w, p
                rows.append(r)

with open(os.path.join(out, "table.md"), "w") as f:
    f.write("| world | profile | map | known | accuracy | Brier | ROC AUC | common accuracy "
            "| common Brier | entropy drop / scan (bits) |\n")
    f.write("|---|---|---|---|---|---|---|---|---|---|\n")
    for r in rows:
        f.write("| %s | %s | %s | %.4f | %.4f | %.4f | %.4f | %.4f | %.4f | %.1f |\n" % (
            r["world"], r["profile"], r["map"], float(r["known_fraction"]), float(r["accuracy"]),
            float(r["brier"]), float(r["roc_auc"]), float(r["common_accuracy"]),
            float(r["common_brier"]), float(r["entropy_drop_per_scan_bits"])))
    # Who leads, per world and profile.
    f.write("\nBest per world and profile (Brier, accuracy, common Brier, common accuracy):\n\n")
    for p in profiles:
        for w in worlds:
            rs = [r for r in rows if r["world"] == w and r["profile"] == p]
            if not rs:
                continue
            best = lambda key, sign: min(rs, key=lambda r: sign * float(r[key]))["map"]
            f.write("- %s, %s: %s, %s, %s, %s\n" % (
                w, p, best("brier", 1), best("accuracy", -1), best("common_brier", 1),
                best("common_accuracy", -1)))


def calibration_lines():
    """(world, profile, line) of every kestrel-calibrate output, profile by profile."""
    for p in profiles:
        for w in sorted(set(worlds + [cal_world])):
            path = os.path.join(out, "%s-%s.cal.txt" % (w, p))
            if os.path.exists(path):
                for line in open(path):
                    yield w, p, line.rstrip("\n")


with open(os.path.join(out, "calibration.md"), "w") as f:
    f.write("Fitted per log (kestrel-calibrate); the profile's values come from %s.\n\n" % cal_world)
    f.write("| world | profile | sensor | sigma (about d_k) | sigma (about d) | p_rand | p_miss |\n")
    f.write("|---|---|---|---|---|---|---|\n")
    for w, p, line in calibration_lines():
        parts = line.split()
        if len(parts) > 5 and parts[0] in ("xtion", "hokuyo") and parts[1] != "mount:":
            f.write("| %s | %s | %s | %s | %s | %s | %s |\n" % (
                w, p, parts[0], parts[1], parts[2], parts[3], parts[4]))

# kestrel-calibrate --mount --truth-sim: "<sensor> mount: ..." then a row per parameter, each
# value with its unit: parameter, fit, std. error (or "held"), configured, true, fit - true (or "-").
value = r"(-?[0-9.]+ (?:mm|deg|ms)|held|-)"
row = re.compile(r"^  (translation [xyz]|rotation [xyz]|stamp offset)\s+" + r"\s+".join([value] * 5))
with open(os.path.join(out, "mount.md"), "w") as f:
    f.write("Mounts and stamp offsets fitted per log (kestrel-calibrate --mount) against what the "
            "simulator drew (stamp offset: the sensor's less the motion capture's latency).\n\n")
    f.write("| world | profile | sensor | parameter | fit | std. error | true | fit - true |\n")
    f.write("|---|---|---|---|---|---|---|---|\n")
    sensor = None
    for w, p, line in calibration_lines():
        parts = line.split()
        if len(parts) > 1 and parts[1] == "mount:":
            sensor = parts[0]
            if "NOT FITTED" in line:
                f.write("| %s | %s | %s | not fitted | | | | |\n" % (w, p, sensor))
            continue
        m = row.match(line)
        if sensor and m:
            fit, se, _, true, diff = m.groups()[1:]
            f.write("| %s | %s | %s | %s | %s | %s | %s | %s |\n" % (
                w, p, sensor, m.group(1), fit, se, true, diff))

try:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    print("tabulate: no matplotlib; no figure", file=sys.stderr)
    sys.exit(0)
maps = []
for r in rows:
    if r["map"] not in maps:
        maps.append(r["map"])
fig, axes = plt.subplots(2, len(profiles), figsize=(6 * len(profiles), 7), squeeze=False)
for j, p in enumerate(profiles):
    for i, (key, title) in enumerate((("brier", "Brier score (lower is better)"),
                                      ("common_accuracy", "accuracy on the cells all maps know"))):
        ax = axes[i][j]
        width = 0.8 / max(1, len(maps))
        for k, m in enumerate(maps):
            xs, ys = [], []
            for n, w in enumerate(worlds):
                for r in rows:
                    if r["world"] == w and r["profile"] == p and r["map"] == m:
                        xs.append(n + k * width)
                        ys.append(float(r[key]))
            ax.bar(xs, ys, width, label=m)
        ax.set_xticks([n + 0.4 - width / 2 for n in range(len(worlds))])
        ax.set_xticklabels(worlds)
        ax.set_title("%s, %s profile" % (title, p))
        if key == "common_accuracy":
            ys = [float(r[key]) for r in rows if r["profile"] == p]
            if ys:
                ax.set_ylim(max(0.0, min(ys) - 0.01), 1.0)
axes[0][0].legend(fontsize=8)
fig.tight_layout()
fig.savefig(os.path.join(out, "fidelity.png"), dpi=90)
