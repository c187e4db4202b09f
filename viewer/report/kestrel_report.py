#!/usr/bin/python3
"""kestrel_report.py: the paper's figures from the CSV files of kestrel-report-export.

Draws, with Debian's python3-matplotlib (Agg backend, no display):
  fig1_map3d.png          the 3D occupancy grid (cells with P above the threshold, coloured by
                          height) beside the ground truth when the run was simulated (Figs. 1, 5);
  fig2_map2d_<k>_t<T>s.png   the 2D projected maps at each kept time with the flown trajectory
                          and the candidate poses as arrows (Figs. 2, 6); with several vehicles
                          (docs/design.md §7.10) the first vehicle's maps and candidates, every
                          vehicle's path in its own colour, named in the legend;
  fig3_entropy.png/.svg   map entropy and known fraction against time, runs overlaid (Figs. 3, 7);
and writes configuration.txt: what every process of the run ran with (its params_t in the log:
command line, then every value under the file it came from, defaults and overrides marked), and
vehicles.txt: one line per vehicle (path length, plans, how its exploration ended).
Each PNG has a sidecar <name>.json with its pixel size and, per panel, the transform from world
(or data) coordinates to image pixels, so a test can check that pixels show what the data holds.

Usage: kestrel_report.py --data DIR --out DIR [--run DATA_DIR:LABEL]... [--label LABEL]
                         [--elev 35] [--azim -60] [--zmin 0.0] [--color height|probability]
"""

import argparse
import csv
import json
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.colors  # noqa: E402
import matplotlib.ticker  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d import proj3d  # noqa: E402

DPI = 100
FIG1_SIZE_PX = (1600, 800)
FIG2_PANEL_PX = (600, 640)
FIG3_SIZE_PX = (1200, 500)


class ReportError(Exception):
    """Bad or missing input data, reported as one line."""


def read_table(path, required=True):
    """A CSV file with a header as a dict of column name -> list of strings."""
    if not os.path.exists(path):
        if required:
            raise ReportError(f"missing {path} (run kestrel-report-export first)")
        return None
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows:
        raise ReportError(f"{path} is empty (no header)")
    header = rows[0]
    columns = {name: [] for name in header}
    for row in rows[1:]:
        if len(row) != len(header):
            raise ReportError(f"{path}: a row has {len(row)} fields, the header {len(header)}")
        for name, value in zip(header, row):
            columns[name].append(value)
    return columns


def floats(table, name):
    return np.array([float(v) for v in table[name]], dtype=float)


def read_meta(data_dir):
    table = read_table(os.path.join(data_dir, "meta.csv"))
    return dict(zip(table["key"], table["value"]))


def read_cells(path):
    """Cell centres (N x 3) and an optional value column from occupied.csv / truth.csv."""
    table = read_table(path)
    xyz = np.column_stack([floats(table, "x_m"), floats(table, "y_m"), floats(table, "z_m")])
    xyz = xyz.reshape(-1, 3)
    p = floats(table, "p") if "p" in table else None
    return xyz, p


def affine_of(ax):
    """The 3x3 matrix from data (or 3D-projected) coordinates to display pixels (origin bottom)."""
    return ax.transData.get_affine().get_matrix().tolist()


def save(fig, out_dir, name, sidecar, svg=False):
    width, height = fig.canvas.get_width_height()
    sidecar = dict(sidecar, width_px=width, height_px=height, png=name + ".png")
    fig.savefig(os.path.join(out_dir, name + ".png"), dpi=DPI)
    if svg:
        fig.savefig(os.path.join(out_dir, name + ".svg"))
    with open(os.path.join(out_dir, name + ".json"), "w") as f:
        json.dump(sidecar, f, indent=1)
    plt.close(fig)
    print(f"kestrel-report: wrote {name}.png" + (f" and {name}.svg" if svg else ""))


# ------------------------------------------------------------------------------------------
# Fig. 1: the 3D map beside the truth.


def lattice_box(meta):
    lo = np.array([float(meta["origin_x_m"]), float(meta["origin_y_m"]), float(meta["origin_z_m"])])
    dims = np.array([int(meta["dims_x"]), int(meta["dims_y"]), int(meta["dims_z"])])
    return lo, lo + dims * float(meta["resolution_m"])


def draw_cells(ax, xyz, values, lo, hi, resolution, args, title, cmap, vmin, vmax):
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(tuple(hi - lo), zoom=1.0)
    ax.zaxis.set_major_locator(matplotlib.ticker.MaxNLocator(3))
    ax.view_init(elev=args.elev, azim=args.azim)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    ax.set_title(title)
    ax.figure.canvas.draw()  # fixes the projection before the marker size is chosen
    # A square marker about as large as one cell seen from this viewpoint (points^2).
    centre = 0.5 * (lo + hi)
    matrix = ax.get_proj()
    px = []
    for axis in range(3):
        a = centre.copy()
        b = centre.copy()
        b[axis] += resolution
        pa = ax.transData.transform(proj3d.proj_transform(*a, matrix)[:2])
        pb = ax.transData.transform(proj3d.proj_transform(*b, matrix)[:2])
        px.append(np.hypot(*(pb - pa)))
    side_pt = max(1.0, 1.15 * max(px)) * 72.0 / DPI
    if len(xyz):
        # Far cells first, so near cells cover them (painter's order along the view direction).
        view = np.array(
            [
                math.cos(math.radians(args.elev)) * math.cos(math.radians(args.azim)),
                math.cos(math.radians(args.elev)) * math.sin(math.radians(args.azim)),
                math.sin(math.radians(args.elev)),
            ]
        )
        order = np.argsort(xyz @ view)
        ax.scatter(
            xyz[order, 0], xyz[order, 1], xyz[order, 2], c=values[order], cmap=cmap, vmin=vmin,
            vmax=vmax, marker="s", s=side_pt**2, linewidths=0, depthshade=False, alpha=1.0,
        )
    ax.figure.canvas.draw()
    bbox = ax.get_window_extent()
    return {
        "kind": "3d",
        "title": title,
        "cells": int(len(xyz)),
        "proj": ax.get_proj().tolist(),
        "affine": affine_of(ax),
        "bbox_px": [bbox.x0, bbox.y0, bbox.x1, bbox.y1],
    }


def figure_map3d(data_dir, out_dir, meta, args):
    lo, hi = lattice_box(meta)
    resolution = float(meta["resolution_m"])
    occupied, p = read_cells(os.path.join(data_dir, "occupied.csv"))
    truth, _ = read_cells(os.path.join(data_dir, "truth.csv"))
    keep = occupied[:, 2] > args.zmin
    occupied, p = occupied[keep], p[keep]
    truth = truth[truth[:, 2] > args.zmin]
    have_truth = meta.get("world", "") != "" and len(truth) > 0
    zlo, zhi = max(lo[2], args.zmin), hi[2]
    fig = plt.figure(figsize=(FIG1_SIZE_PX[0] / DPI, FIG1_SIZE_PX[1] / DPI), dpi=DPI)
    fig.subplots_adjust(left=0.0, right=0.93, bottom=0.02, top=0.93, wspace=0.02)
    panels = []
    threshold = float(meta["occupied_threshold"])
    if args.color == "probability":
        values, cmap, vmin, vmax, label = p, "inferno_r", threshold, 1.0, "P(occupied)"
    else:
        values, cmap, vmin, vmax, label = occupied[:, 2], "viridis", zlo, zhi, "height z (m)"
    ax = fig.add_subplot(1, 2 if have_truth else 1, 1, projection="3d")
    panels.append(
        dict(
            draw_cells(ax, occupied, values, lo, hi, resolution, args,
                       f"map: {len(occupied)} cells with P > {threshold:g}", cmap, vmin, vmax),
            name="map",
        )
    )
    if have_truth:
        ax2 = fig.add_subplot(1, 2, 2, projection="3d")
        panels.append(
            dict(
                draw_cells(ax2, truth, truth[:, 2], lo, hi, resolution, args,
                           f"ground truth: {os.path.basename(meta['world'])}", "viridis", zlo, zhi),
                name="truth",
            )
        )
    mappable = plt.cm.ScalarMappable(cmap=cmap, norm=plt.Normalize(vmin, vmax))
    colorbar_axes = fig.add_axes([0.95, 0.25, 0.012, 0.5])
    fig.colorbar(mappable, cax=colorbar_axes, label=label)
    # Colour bar placement moves the axes: recompute the transforms.
    fig.canvas.draw()
    for panel, axis in zip(panels, [a for a in fig.axes if a.name == "3d"]):
        panel["proj"] = axis.get_proj().tolist()
        panel["affine"] = affine_of(axis)
        b = axis.get_window_extent()
        panel["bbox_px"] = [b.x0, b.y0, b.x1, b.y1]
    save(fig, out_dir, "fig1_map3d", {"panels": panels, "zmin_m": args.zmin,
                                      "elev_deg": args.elev, "azim_deg": args.azim})


# ------------------------------------------------------------------------------------------
# Fig. 2: 2D maps, trajectory and candidates at chosen times.

MAP2D_TITLES = {"collision": "collision map C", "combined": "combined map B",
                "entropy": "entropy map E"}
# Path colours of the vehicles when there are several (one vehicle: tab:red, as always); none is
# the candidates' blue or orange.
VEHICLE_COLORS = ["tab:red", "tab:green", "tab:purple", "tab:brown", "tab:pink", "tab:cyan",
                  "tab:olive", "black"]


def read_vehicles(data_dir):
    """The run's vehicles (vehicles.csv) as dicts; an export without it: one, trajectory.csv."""
    path = os.path.join(data_dir, "vehicles.csv")
    if not os.path.exists(path):
        return [{"vehicle": "0", "prefix": "", "trajectory_file": "trajectory.csv"}]
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def vehicle_paths(data_dir):
    """Per vehicle: prefix, colour, label and its trajectory (time, x, y)."""
    vehicles = read_vehicles(data_dir)
    several = len(vehicles) > 1
    out = []
    for i, v in enumerate(vehicles):
        trajectory = read_table(os.path.join(data_dir, v["trajectory_file"]))
        out.append({
            "prefix": v["prefix"],
            "file": v["trajectory_file"],
            "color": VEHICLE_COLORS[i % len(VEHICLE_COLORS)] if several else "tab:red",
            "label": f"{v['prefix'] or '(no prefix)'} path" if several else "trajectory",
            "t": floats(trajectory, "time_s"),
            "x": floats(trajectory, "x_m"),
            "y": floats(trajectory, "y_m"),
        })
    return out


def figure_map2d(data_dir, out_dir):
    index = read_table(os.path.join(data_dir, "map2d_index.csv"))
    if not index["k"]:
        print("kestrel-report: no MAP2D_* messages in the log: no 2D map figures")
        return
    paths = vehicle_paths(data_dir)
    several = len(paths) > 1
    candidates = read_table(os.path.join(data_dir, "candidates.csv"))
    c_plan = np.array([int(v) for v in candidates["plan"]], dtype=int)
    rows = list(zip(*[index[name] for name in index]))
    columns = list(index)
    by_k = {}
    for row in rows:
        entry = dict(zip(columns, row))
        by_k.setdefault(int(entry["k"]), []).append(entry)
    for k in sorted(by_k):
        entries = by_k[k]
        request_s = float(entries[0]["request_time_s"])
        n = len(entries)
        fig, axes = plt.subplots(
            1, n, figsize=(FIG2_PANEL_PX[0] * n / DPI, FIG2_PANEL_PX[1] / DPI), dpi=DPI,
            squeeze=False,
        )
        panels = []
        for ax, e in zip(axes[0], entries):
            values = np.loadtxt(os.path.join(data_dir, e["file"]), delimiter=",", ndmin=2)
            ox, oy, r = float(e["origin_x_m"]), float(e["origin_y_m"]), float(e["resolution_m"])
            w, h = int(e["width"]), int(e["height"])
            if values.shape != (h, w):
                raise ReportError(f"{e['file']}: {values.shape} values, index says {h} x {w}")
            extent = [ox, ox + w * r, oy, oy + h * r]
            ax.imshow(values, origin="lower", extent=extent, cmap="gray_r", vmin=0.0, vmax=1.0,
                      interpolation="nearest")
            for path in paths:
                upto = path["t"] <= request_s
                ax.plot(path["x"][upto], path["y"][upto], "-", color=path["color"], lw=1.5,
                        label=path["label"])
                if upto.any():
                    ax.plot(path["x"][upto][-1:], path["y"][upto][-1:], "o", color=path["color"],
                            ms=6)
            plan = int(e["plan"])
            shown = 0
            if plan >= 0:
                sel = c_plan == plan
                cx = floats(candidates, "x_m")[sel]
                cy = floats(candidates, "y_m")[sel]
                yaw = floats(candidates, "yaw_rad")[sel]
                chosen = floats(candidates, "chosen")[sel] > 0
                shown = int(sel.sum())
                arrow = 0.35
                ax.quiver(cx[~chosen], cy[~chosen], arrow * np.cos(yaw[~chosen]),
                          arrow * np.sin(yaw[~chosen]), color="tab:blue", angles="xy",
                          scale_units="xy", scale=1, width=0.004, label="candidates")
                if chosen.any():
                    ax.quiver(cx[chosen], cy[chosen], 2 * arrow * np.cos(yaw[chosen]),
                              2 * arrow * np.sin(yaw[chosen]), color="tab:orange", angles="xy",
                              scale_units="xy", scale=1, width=0.008, label="chosen")
            ax.set_xlim(extent[0], extent[1])
            ax.set_ylim(extent[2], extent[3])
            ax.set_aspect("equal")
            ax.set_xlabel("x (m)")
            ax.set_ylabel("y (m)")
            owner = f" of {paths[0]['prefix']}" if several else ""
            ax.set_title(f"{MAP2D_TITLES.get(e['name'], e['name'])}{owner}, t = {request_s:g} s\n"
                         f"(h = {float(e['height_m']):.2f} m, {shown} candidates)")
            ax.legend(loc="lower right", fontsize=7)
            panels.append({"kind": "2d", "name": e["name"], "file": e["file"],
                           "xlim": list(ax.get_xlim()), "ylim": list(ax.get_ylim())})
        fig.tight_layout()
        fig.canvas.draw()
        for panel, ax in zip(panels, axes[0]):
            panel["affine"] = affine_of(ax)
            b = ax.get_window_extent()
            panel["bbox_px"] = [b.x0, b.y0, b.x1, b.y1]
        save(fig, out_dir, f"fig2_map2d_{k}_t{request_s:g}s",
             {"panels": panels, "time_s": request_s,
              "vehicles": [{"prefix": p["prefix"], "file": p["file"],
                            "color": matplotlib.colors.to_hex(p["color"])} for p in paths]})


# ------------------------------------------------------------------------------------------
# Fig. 3: entropy and known fraction against time, runs overlaid.


def figure_entropy(runs, out_dir):
    fig, (ax_h, ax_k) = plt.subplots(
        1, 2, figsize=(FIG3_SIZE_PX[0] / DPI, FIG3_SIZE_PX[1] / DPI), dpi=DPI)
    lines = []
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    any_known = False
    for i, (data_dir, label) in enumerate(runs):
        table = read_table(os.path.join(data_dir, "timeseries.csv"))
        t = floats(table, "time_s")
        h = floats(table, "entropy_nats")
        if np.all(np.isnan(h)):
            h = floats(table, "entropy_replica_nats")
        known = floats(table, "known_fraction")
        color = colors[i % len(colors)]
        # The first run (the report's own) is drawn last, on top of the others.
        order = len(runs) if i == 0 else i
        ax_h.plot(t, h, "-", color=color, lw=2, label=label, zorder=2 + order)
        ok = ~np.isnan(known)
        if ok.any():
            any_known = True
            ax_k.plot(t[ok], known[ok], "-", color=color, lw=2, label=label, zorder=2 + order)
        lines.append({"label": label, "color": color, "data": data_dir, "drawn_order": order})
    ax_h.set_xlabel("time (s)")
    ax_h.set_ylabel("map entropy H (nats)")
    ax_h.set_title("map entropy")
    ax_h.grid(True, alpha=0.3)
    ax_h.legend()
    ax_k.set_xlabel("time (s)")
    ax_k.set_ylabel("known fraction of observable cells")
    ax_k.set_ylim(0.0, 1.0)
    ax_k.set_title("known fraction" if any_known else "known fraction (no world given)")
    ax_k.grid(True, alpha=0.3)
    if any_known:
        ax_k.legend()
    fig.tight_layout()
    fig.canvas.draw()
    panels = []
    for name, ax in (("entropy", ax_h), ("known_fraction", ax_k)):
        b = ax.get_window_extent()
        panels.append({"kind": "2d", "name": name, "affine": affine_of(ax),
                       "bbox_px": [b.x0, b.y0, b.x1, b.y1], "xlim": list(ax.get_xlim()),
                       "ylim": list(ax.get_ylim())})
    save(fig, out_dir, "fig3_entropy", {"panels": panels, "runs": lines}, svg=True)


def vehicle_line(v):
    """One vehicle's summary line from its vehicles.csv row."""
    name = v["prefix"] or "vehicle"
    line = (f"{name}: path {float(v['path_length_m']):.2f} m ({v['valid_poses']} valid poses), "
            f"{v['plans']} plans")
    state = int(v["final_state"])
    if state < 0:
        return line + ", no exploration status"
    # The name from the explorer's own table (kestrel-report-export writes it).
    state_name = v.get("final_state_name") or str(state)
    line += f", last status {state_name} at {float(v['final_time_s']):.1f} s"
    # The explorer's DONE status says "home: land sent (<end rule>, <landing>)".
    line += "; land sent" if v["land_sent"] == "1" else "; no land sent"
    if v["final_reason"]:
        line += f": {v['final_reason']}"
    return line


def write_vehicles(data_dir, out_dir):
    """vehicles.txt: one line per vehicle; returns its path or None (an older export)."""
    if not os.path.exists(os.path.join(data_dir, "vehicles.csv")):
        return None
    vehicles = read_vehicles(data_dir)
    path = os.path.join(out_dir, "vehicles.txt")
    with open(path, "w") as out:
        for v in vehicles:
            out.write(vehicle_line(v) + "\n")
    print(f"kestrel-report: wrote vehicles.txt ({len(vehicles)} "
          f"vehicle{'s' if len(vehicles) != 1 else ''})")
    for v in vehicles:
        print(f"  {vehicle_line(v)}")
    return path


def write_configuration(data_dir, out_dir):
    """configuration.txt from config_processes.csv and config.csv; returns its path or None."""
    processes_path = os.path.join(data_dir, "config_processes.csv")
    values_path = os.path.join(data_dir, "config.csv")
    if not (os.path.exists(processes_path) and os.path.exists(values_path)):
        return None
    with open(processes_path, newline="") as f:
        processes = list(csv.DictReader(f))
    with open(values_path, newline="") as f:
        values = list(csv.DictReader(f))
    path = os.path.join(out_dir, "configuration.txt")
    counts = {"file": 0, "override": 0, "default": 0}
    with open(path, "w") as out:
        if not processes:
            out.write("The log holds no process configuration (no PARAMS_* message).\n")
        for p in processes:
            out.write(f"{p['process']} on {p['host']}, pid {p['pid']}"
                      + (f", run {p['run_id']}" if p["run_id"] else "")
                      + f" ({p['channel']}, epoch {p['epoch']})\n")
            if p["command_line"]:
                out.write(f"  command: {p['command_line']}\n")
            current_file = None
            for v in values:
                if v["channel"] != p["channel"] or v["epoch"] != p["epoch"]:
                    continue
                if v["file"] != current_file:
                    current_file = v["file"]
                    out.write(f"  {current_file}:\n")
                line = f"    {v['key']}: {v['value']}"
                if v["source"] != "file":
                    line = line.ljust(max(len(line) + 2, 44)) + f"# {v['source']}"
                counts[v["source"]] = counts.get(v["source"], 0) + 1
                out.write(line + "\n")
    print(f"kestrel-report: wrote configuration.txt ({len(processes)} processes; "
          f"{counts['file']} values from files, {counts['override']} overrides, "
          f"{counts['default']} defaults)")
    return path


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--data", required=True, help="kestrel-report-export output of the run")
    parser.add_argument("--out", required=True, help="directory for the figures")
    parser.add_argument("--label", default="run", help="legend label of the run")
    parser.add_argument("--run", action="append", default=[],
                        help="DATA_DIR:LABEL of another run to overlay in fig. 3")
    parser.add_argument("--elev", type=float, default=35.0, help="3D view elevation, deg")
    parser.add_argument("--azim", type=float, default=-60.0, help="3D view azimuth, deg")
    parser.add_argument("--zmin", type=float, default=0.0,
                        help="draw 3D cells whose centre is above this height (hides the floor)")
    parser.add_argument("--color", choices=["height", "probability"], default="height")
    parser.add_argument("--only", choices=["map3d", "map2d", "entropy"], action="append",
                        help="draw only these figures")
    args = parser.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    runs = [(args.data, args.label)]
    for spec in args.run:
        if ":" not in spec:
            raise ReportError(f"--run {spec}: expected DATA_DIR:LABEL")
        path, label = spec.rsplit(":", 1)
        runs.append((path, label))
    meta = read_meta(args.data)
    only = set(args.only or ["map3d", "map2d", "entropy"])
    if "map3d" in only:
        figure_map3d(args.data, args.out, meta, args)
    if "map2d" in only:
        figure_map2d(args.data, args.out)
    if "entropy" in only:
        figure_entropy(runs, args.out)
    if args.only is None:
        write_configuration(args.data, args.out)
        write_vehicles(args.data, args.out)
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except ReportError as e:
        print(f"kestrel-report: error: {e}", file=sys.stderr)
        sys.exit(1)
