#!/usr/bin/python3
"""Checks kestrel-report's figures against the data they were drawn from (the report test).

For each figure: the PNG exists with the expected pixel size, and its pixels show content where
the data says there is some, found through the transforms in the figure's .json sidecar:
  fig1  the map panel's coloured pixels lie where the world's ground truth projects (coarse
        blocks of the truth's occupied cells rendered here in the same projection), and cover
        where the map's occupied cells project; the truth panel matches the truth both ways;
  fig2  occupied 2D-map cells are dark, the trajectory is red (with several vehicles: each
        vehicle's samples lie on a line of its colour, named in the sidecar), candidates have
        arrows;
  fig3  each run's entropy and known-fraction samples lie on a line of that run's colour.
Exits 1 and lists what failed; an empty or displaced map must fail.

Usage: report_check_figures.py --figures DIR --data DATA_DIR [--only map3d|map2d|entropy]...
"""

import argparse
import csv
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.colors  # noqa: E402
import matplotlib.image  # noqa: E402
import numpy as np  # noqa: E402

BLOCK_PX = 10


def table(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return {name: [r[i] for r in rows[1:]] for i, name in enumerate(rows[0])}


def column(t, name):
    return np.array([float(v) for v in t[name]], dtype=float)


def cells(path):
    t = table(path)
    return np.column_stack([column(t, "x_m"), column(t, "y_m"), column(t, "z_m")]).reshape(-1, 3)


class Checker:
    def __init__(self):
        self.failures = []
        self.notes = []

    def expect(self, ok, what):
        (self.notes if ok else self.failures).append(("ok   " if ok else "FAIL ") + what)
        return ok


def load_png(path, sidecar, checker, width, height):
    if not checker.expect(os.path.exists(path), f"{os.path.basename(path)} exists"):
        return None
    image = matplotlib.image.imread(path)[:, :, :3]
    checker.expect(image.shape[1] == width and image.shape[0] == height,
                   f"{os.path.basename(path)} is {width}x{height} px "
                   f"(got {image.shape[1]}x{image.shape[0]})")
    checker.expect(sidecar["width_px"] == width and sidecar["height_px"] == height,
                   f"{os.path.basename(path)} sidecar size")
    return image


def to_pixels_3d(panel, xyz, height_px):
    """World points to (column, row) image pixels with the panel's projection and affine."""
    proj = np.array(panel["proj"])
    affine = np.array(panel["affine"])
    v = np.column_stack([xyz, np.ones(len(xyz))]) @ proj.T
    x2, y2 = v[:, 0] / v[:, 3], v[:, 1] / v[:, 3]
    d = np.column_stack([x2, y2, np.ones(len(xyz))]) @ affine.T
    return d[:, 0], height_px - d[:, 1]


def to_pixels_2d(panel, x, y, height_px):
    affine = np.array(panel["affine"])
    d = np.column_stack([x, y, np.ones(len(x))]) @ affine.T
    return d[:, 0], height_px - d[:, 1]


def panel_slice(panel, height_px):
    x0, y0, x1, y1 = panel["bbox_px"]
    return (int(max(0, height_px - y1)), int(height_px - y0)), (int(max(0, x0)), int(x1))


def block_set(cols, rows):
    return set(zip((cols // BLOCK_PX).astype(int), (rows // BLOCK_PX).astype(int)))


def dilate(blocks):
    return {(bx + dx, by + dy) for bx, by in blocks for dx in (-1, 0, 1) for dy in (-1, 0, 1)}


def content_blocks(image, panel):
    """Blocks of the panel with at least 3 coloured (not grey, not white) pixels."""
    h = image.shape[0]
    (r0, r1), (c0, c1) = panel_slice(panel, h)
    sub = image[r0:r1, c0:c1]
    saturation = sub.max(axis=2) - sub.min(axis=2)
    rows, cols = np.nonzero(saturation > 0.15)
    rows, cols = rows + r0, cols + c0
    blocks = {}
    for key in zip(cols // BLOCK_PX, rows // BLOCK_PX):
        blocks[key] = blocks.get(key, 0) + 1
    return {k for k, n in blocks.items() if n >= 3}


def check_map3d(fig_dir, data_dir, c):
    path = os.path.join(fig_dir, "fig1_map3d.png")
    if not c.expect(os.path.exists(path.replace(".png", ".json")), "fig1_map3d.json exists"):
        return
    side = json.load(open(path.replace(".png", ".json")))
    image = load_png(path, side, c, 1600, 800)
    if image is None:
        return
    h = image.shape[0]
    zmin = side["zmin_m"]
    truth = cells(os.path.join(data_dir, "truth.csv"))
    truth = truth[truth[:, 2] > zmin]
    occupied = cells(os.path.join(data_dir, "occupied.csv"))
    occupied = occupied[occupied[:, 2] > zmin]
    panels = {p["name"]: p for p in side["panels"]}
    if not c.expect("map" in panels and "truth" in panels, "fig1 has a map and a truth panel"):
        return
    for name in ("map", "truth"):
        panel = panels[name]
        content = content_blocks(image, panel)
        truth_blocks = block_set(*to_pixels_3d(panel, truth, h))
        truth_near = dilate(truth_blocks)
        precision = len(content & truth_near) / max(1, len(content))
        c.expect(len(content) >= 30, f"fig1 {name}: {len(content)} blocks with content (>= 30)")
        c.expect(precision >= 0.9,
                 f"fig1 {name}: {precision:.3f} of the coloured blocks lie on the ground truth "
                 f"(>= 0.9)")
        if name == "truth":
            recall = len(dilate(content) & truth_blocks) / max(1, len(truth_blocks))
            c.expect(recall >= 0.9, f"fig1 truth: {recall:.3f} of the truth's blocks coloured")
        else:
            map_blocks = block_set(*to_pixels_3d(panel, occupied, h))
            recall = len(dilate(content) & map_blocks) / max(1, len(map_blocks))
            c.expect(len(map_blocks) > 0 and recall >= 0.85,
                     f"fig1 map: {recall:.3f} of the blocks where the map's {len(occupied)} "
                     f"occupied cells project are coloured (>= 0.85)")
            c.expect(len(content) >= 0.05 * len(truth_blocks),
                     f"fig1 map: coloured blocks {len(content)} >= 5% of the truth's "
                     f"{len(truth_blocks)}")


def near_colour(image, cols, rows, rgb, radius, tolerance):
    """For each point, whether a pixel within `radius` px has colour within `tolerance`."""
    h, w = image.shape[:2]
    hits = []
    for col, row in zip(cols, rows):
        r0, r1 = int(max(0, row - radius)), int(min(h, row + radius + 1))
        c0, c1 = int(max(0, col - radius)), int(min(w, col + radius + 1))
        if r0 >= r1 or c0 >= c1:
            hits.append(False)
            continue
        d = np.abs(image[r0:r1, c0:c1] - np.array(rgb)).max(axis=2)
        hits.append(bool((d < tolerance).any()))
    return np.array(hits, dtype=bool)


def check_map2d(fig_dir, data_dir, c):
    index = table(os.path.join(data_dir, "map2d_index.csv"))
    by_k = {}
    for i, k in enumerate(index["k"]):
        by_k.setdefault(int(k), []).append({name: index[name][i] for name in index})
    if not c.expect(len(by_k) > 0, "the run has 2D maps"):
        return
    cand = table(os.path.join(data_dir, "candidates.csv"))
    plan = column(cand, "plan").astype(int)
    blue = matplotlib.colors.to_rgb("tab:blue")
    orange = matplotlib.colors.to_rgb("tab:orange")
    for k, entries in sorted(by_k.items()):
        t = float(entries[0]["request_time_s"])
        name = f"fig2_map2d_{k}_t{t:g}s"
        path = os.path.join(fig_dir, name + ".png")
        if not c.expect(os.path.exists(path.replace(".png", ".json")), f"{name}.json exists"):
            continue
        side = json.load(open(path.replace(".png", ".json")))
        image = load_png(path, side, c, 600 * len(entries), 640)
        if image is None:
            continue
        h = image.shape[0]
        gray = image.mean(axis=2)
        # Each vehicle's path and colour (an older sidecar: one vehicle, trajectory.csv, red).
        vehicles = side.get("vehicles") or [{"prefix": "", "file": "trajectory.csv",
                                             "color": matplotlib.colors.to_hex("tab:red")}]
        c.expect(len(vehicles) == len(table(os.path.join(data_dir, "vehicles.csv"))["prefix"])
                 if os.path.exists(os.path.join(data_dir, "vehicles.csv")) else True,
                 f"{name}: every vehicle of vehicles.csv is drawn")
        for e, panel in zip(entries, side["panels"]):
            values = np.loadtxt(os.path.join(data_dir, e["file"]), delimiter=",", ndmin=2)
            ox, oy, r = float(e["origin_x_m"]), float(e["origin_y_m"]), float(e["resolution_m"])
            iy, ix = np.nonzero(values > 0.7)
            cols, rows = to_pixels_2d(panel, ox + (ix + 0.5) * r, oy + (iy + 0.5) * r, h)
            dark = [gray[int(rw), int(cl)] < 0.35 for cl, rw in zip(cols, rows)]
            c.expect(len(dark) > 0 and np.mean(dark) >= 0.8,
                     f"{name} {e['name']}: {np.mean(dark) if dark else 0:.2f} of {len(dark)} "
                     "occupied cells drawn dark (>= 0.8)")
            for v in vehicles:
                trajectory = table(os.path.join(data_dir, v["file"]))
                tt, tx, ty = (column(trajectory, "time_s"), column(trajectory, "x_m"),
                              column(trajectory, "y_m"))
                upto = tt <= t
                cols, rows = to_pixels_2d(panel, tx[upto][::10], ty[upto][::10], h)
                colour = matplotlib.colors.to_rgb(v["color"])
                on_path = near_colour(image, cols, rows, colour, 3, 0.2)
                what = "red" if len(vehicles) == 1 else f"{v['prefix']}'s {v['color']}"
                c.expect(len(on_path) > 0 and on_path.mean() >= 0.9,
                         f"{name} {e['name']}: {on_path.mean() if len(on_path) else 0:.2f} of "
                         f"the trajectory samples are on a {what} line (>= 0.9)")
            sel = plan == int(e["plan"])
            cols, rows = to_pixels_2d(panel, column(cand, "x_m")[sel], column(cand, "y_m")[sel], h)
            arrows = near_colour(image, cols, rows, blue, 4, 0.2) | near_colour(
                image, cols, rows, orange, 4, 0.2)
            if len(arrows) == 0:  # the plan shown has no candidates (e.g. returning home)
                c.expect(True, f"{name} {e['name']}: the plan shown has no candidates")
                continue
            c.expect(arrows.mean() >= 0.9,
                     f"{name} {e['name']}: {arrows.mean():.2f} of "
                     f"{len(arrows)} candidates have an arrow (>= 0.9)")


def check_entropy(fig_dir, c, expect_runs):
    path = os.path.join(fig_dir, "fig3_entropy.png")
    if not c.expect(os.path.exists(path.replace(".png", ".json")), "fig3_entropy.json exists"):
        return
    side = json.load(open(path.replace(".png", ".json")))
    image = load_png(path, side, c, 1200, 500)
    c.expect(os.path.exists(path.replace(".png", ".svg")), "fig3_entropy.svg exists")
    if image is None:
        return
    h = image.shape[0]
    c.expect(len(side["runs"]) == expect_runs,
             f"fig3 overlays {len(side['runs'])} runs (expected {expect_runs})")
    panels = {p["name"]: p for p in side["panels"]}
    series = []
    for run in side["runs"]:
        ts = table(os.path.join(run["data"], "timeseries.csv"))
        series.append((run, column(ts, "time_s"), {"entropy": column(ts, "entropy_nats"),
                                                   "known_fraction": column(ts, "known_fraction")}))
    for i, (run, t, values) in enumerate(series):
        rgb = matplotlib.colors.to_rgb(run["color"])
        for panel_name in ("entropy", "known_fraction"):
            v = values[panel_name]
            ok = ~np.isnan(v)
            cols, rows = to_pixels_2d(panels[panel_name], t[ok], v[ok], h)
            # Samples where a line drawn later (zorder in "drawn_order") passes within 4 px may
            # be hidden: those are not evidence either way.
            hidden = np.zeros(len(cols), dtype=bool)
            for j, (other, t2, values2) in enumerate(series):
                if j == i or other["drawn_order"] < run["drawn_order"]:
                    continue
                v2 = values2[panel_name]
                ok2 = ~np.isnan(v2)
                if ok2.sum() < 2:
                    continue
                _, rows2 = to_pixels_2d(panels[panel_name], t[ok],
                                        np.interp(t[ok], t2[ok2], v2[ok2]), h)
                hidden |= np.abs(rows2 - rows) < 4
            on = near_colour(image, cols[~hidden], rows[~hidden], rgb, 2, 0.12)
            if i > 0 and len(on) < 5:  # an overlaid run that follows a later one: nothing to see
                c.expect(True, f"fig3 {panel_name} of {run['label']}: under later lines")
                continue
            c.expect(len(on) >= 5 and on.mean() >= 0.9,
                     f"fig3 {panel_name} of {run['label']}: {on.mean() if len(on) else 0:.2f} of "
                     f"{len(on)} visible samples on its line (>= 0.9; "
                     f"{int(hidden.sum())} under later lines)")


def main(argv):
    parser = argparse.ArgumentParser()
    parser.add_argument("--figures", required=True)
    parser.add_argument("--data", required=True)
    parser.add_argument("--only", action="append", choices=["map3d", "map2d", "entropy"])
    parser.add_argument("--runs", type=int, default=1, help="runs expected in fig3")
    args = parser.parse_args(argv)
    only = set(args.only or ["map3d", "map2d", "entropy"])
    c = Checker()
    if "map3d" in only:
        check_map3d(args.figures, args.data, c)
    if "map2d" in only:
        check_map2d(args.figures, args.data, c)
    if "entropy" in only:
        check_entropy(args.figures, c, args.runs)
    for line in c.notes + c.failures:
        print(line)
    print(f"{len(c.failures)} failed, {len(c.notes)} passed")
    return 1 if c.failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
