#!/usr/bin/env python3
"""Faults and frame time along the flight, capped against uncapped: an SVG from the frames.csv of
bench/larger_than_memory.sh's runs (no plotting library needed).

    bench/plot_larger_than_memory.py OUT.svg LABEL=RUN_DIR [LABEL=RUN_DIR ...]

Top panel: frame time (ms, a 15-frame running median) against the frame number; bottom panel:
render-thread major faults summed since the first frame (log scale, 0 drawn at the axis).
"""
import csv
import math
import sys

COLOURS = ["#d62728", "#1f77b4", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f"]
WIDTH, PANEL, LEFT, RIGHT, TOP, GAP = 900, 260, 70, 230, 30, 60


def median(values):
    s = sorted(values)
    return s[len(s) // 2]


def read(run_dir):
    with open(f"{run_dir}/frames.csv") as f:
        rows = list(csv.DictReader(f))
    ms = [float(r["frame_ms"]) for r in rows]
    smooth = [median(ms[max(0, i - 7):i + 8]) for i in range(len(ms))]
    total, cumulative = 0, []
    for r in rows:
        total += int(r["render_thread_major_faults"])
        cumulative.append(total)
    return smooth, cumulative


def polyline(points, colour):
    # Every third frame (and the last): the lines look the same at this width, a third the size.
    kept = points[::3] + ([points[-1]] if (len(points) - 1) % 3 else [])
    text = " ".join(f"{x:.1f},{y:.1f}" for x, y in kept)
    return f'<polyline fill="none" stroke="{colour}" stroke-width="1.5" points="{text}"/>'


def main():
    out, runs = sys.argv[1], [a.split("=", 1) for a in sys.argv[2:]]
    series = [(label, *read(d)) for label, d in runs]
    frames = max(len(s[1]) for s in series)
    ms_max = max(max(s[1]) for s in series) * 1.1
    faults_max = max(max(s[2]) for s in series)
    decades = max(1, math.ceil(math.log10(faults_max + 1)))
    plot_w = WIDTH - LEFT - RIGHT
    height = TOP + 2 * PANEL + GAP + 50
    x = lambda i: LEFT + plot_w * i / max(1, frames - 1)
    y_ms = lambda v: TOP + PANEL * (1 - v / ms_max)
    top2 = TOP + PANEL + GAP
    y_faults = lambda v: top2 + PANEL * (1 - math.log10(v + 1) / decades)
    svg = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{height}" '
           'font-family="sans-serif" font-size="12">',
           f'<rect width="{WIDTH}" height="{height}" fill="white"/>']
    for top, title in ((TOP, "frame time, ms (15-frame running median)"),
                       (top2, "render-thread major faults since the first frame (log)")):
        svg.append(f'<rect x="{LEFT}" y="{top}" width="{plot_w}" height="{PANEL}" fill="none" '
                   'stroke="#888"/>')
        svg.append(f'<text x="{LEFT}" y="{top - 8}">{title}</text>')
    for k in range(5):
        v = ms_max * k / 4
        svg.append(f'<text x="{LEFT - 8}" y="{y_ms(v) + 4:.1f}" text-anchor="end">{v:.0f}</text>')
    for d in range(decades + 1):
        v = 10 ** d - 1
        svg.append(f'<text x="{LEFT - 8}" y="{y_faults(v) + 4:.1f}" text-anchor="end">'
                   f'{10 ** d if d else 0}</text>')
    for k in range(5):
        i = (frames - 1) * k // 4
        svg.append(f'<text x="{x(i):.1f}" y="{height - 28}" text-anchor="middle">{i}</text>')
    svg.append(f'<text x="{LEFT + plot_w / 2}" y="{height - 10}" text-anchor="middle">frame of '
               'the Mars flight</text>')
    for n, (label, smooth, cumulative) in enumerate(series):
        colour = COLOURS[n % len(COLOURS)]
        svg.append(polyline([(x(i), y_ms(v)) for i, v in enumerate(smooth)], colour))
        svg.append(polyline([(x(i), y_faults(v)) for i, v in enumerate(cumulative)], colour))
        ly = TOP + 16 + 18 * n
        svg.append(f'<line x1="{WIDTH - RIGHT + 15}" y1="{ly - 4}" x2="{WIDTH - RIGHT + 35}" '
                   f'y2="{ly - 4}" stroke="{colour}" stroke-width="2"/>')
        svg.append(f'<text x="{WIDTH - RIGHT + 40}" y="{ly}">{label}</text>')
    svg.append("</svg>")
    with open(out, "w") as f:
        f.write("\n".join(svg) + "\n")


if __name__ == "__main__":
    main()
