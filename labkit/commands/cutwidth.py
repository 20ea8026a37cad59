"""``labkit cutwidth``: characterise cut width against power and speed ([CBR40] figure 10).

``labkit cutwidth pattern --powers 500:2500:5 --speeds 300:1500:5 -o GRID.gcode``
    a power × speed test grid (and GRID.json, its layout);
``labkit cutwidth measure SCAN.png --layout GRID.json [--dpi D | --reference …] -o WIDTHS.csv``
    the width of every line in a scan (and WIDTHS.png, annotated for checking by eye);
``labkit cutwidth fit WIDTHS.csv [--model dose|empirical|both] [--json] [-o FIT.json]``
    the dose and empirical models, cross-validated, and cut-through by a logistic model;
``labkit cutwidth settings --width 0.2 --speed 600 --fit FIT.json``
    the power for a width (or the speed, with ``--power``), with its band;
``labkit cutwidth window FIT.json -o WINDOW.png``
    the process window: width contours over power × speed;
``labkit cutwidth source SOURCE.csv [--nominal MW] [-o CURVES.png]``
    the laser itself: threshold current, slope efficiency, I–V line, efficiency ([CBR40] §F).
"""

from __future__ import annotations

import json


def add_cutwidth_arguments(parser):
    from labkit.commands._args import add_dialect_option, add_line_grid_options, integer, number

    sub = parser.add_subparsers(dest="action", required=True, metavar="ACTION")

    p = sub.add_parser("pattern", help="write a power × speed test grid and its layout JSON")
    p.add_argument("--powers", required=True, metavar="LO:HI:N",
                   help="optical powers, mW: LO:HI:N (N steps) or a comma list")
    p.add_argument("--speeds", required=True, metavar="LO:HI:N",
                   help="speeds, mm/min: LO:HI:N (N steps) or a comma list")
    p.add_argument("--scale", choices=("linear", "geometric"), default="linear",
                   help="spacing of LO:HI:N ranges (default linear)")
    p.add_argument("-o", "--output", required=True, metavar="GRID.gcode",
                   help="G-code to write; the layout goes to the same name with .json")
    add_line_grid_options(p, line_mm=10.0, pitch_mm=2.0, overscan_mm=3.0)
    p.add_argument("--repeats", type=integer(1, 100), default=1, metavar="N", help="copies of each line (default 1)")
    p.add_argument("--passes", type=integer(1, 100), default=1, metavar="N", help="passes per line (default 1)")
    p.add_argument("--max-power", type=number(1, 1e6), default=None, metavar="MW",
                   help="power at full S, mW (default the CBR-40's 2500)")
    add_dialect_option(p)

    m = sub.add_parser("measure", help="measure every line's width in a scan of the burned grid")
    m.add_argument("scan", metavar="SCAN.png", help="scan or photograph (burn dark on light)")
    m.add_argument("--layout", required=True, metavar="GRID.json", help="layout written by 'pattern'")
    m.add_argument("--dpi", type=number(10, 100_000), default=None, metavar="DPI",
                   help="scan resolution (default: the image file's, else --reference)")
    m.add_argument("--reference", type=number(-1e7, 1e7), nargs=5, default=None,
                   metavar=("COL0", "ROW0", "COL1", "ROW1", "MM"),
                   help="a length marked in the image: two pixel positions and their distance in mm")
    m.add_argument("-o", "--output", required=True, metavar="WIDTHS.csv", help="widths CSV to write")
    m.add_argument("--annotated", default=None, metavar="PNG",
                   help="annotated image for checking by eye (default: the CSV's name with .png)")
    for name, default, what in (("material", "unknown", "material burned"),
                                ("machine", "unknown", "machine used"), ("notes", "", "free text")):
        m.add_argument(f"--{name}", default=default, help=f"{what} (goes into every row)")
    m.add_argument("--thickness", type=number(0, 1000), default=float("nan"), metavar="MM",
                   help="material thickness, mm")
    m.add_argument("--beam", type=number(0, 100), default=float("nan"), metavar="MM", help="beam radius, mm")

    f = sub.add_parser("fit", help="fit the dose and empirical models to a widths CSV")
    f.add_argument("csv", metavar="WIDTHS.csv", help="tidy widths CSV (power_mw, speed_mm_min, width_mm, …)")
    f.add_argument("--model", choices=("dose", "empirical", "both"), default="both",
                   help="which models (default both, cross-validated)")
    f.add_argument("--degree", type=integer(1, 3), default=2, metavar="D",
                   help="degree of the empirical polynomial in ln P, ln v (default 2)")
    f.add_argument("--level", type=number(0.5, 0.999), default=0.95, metavar="L",
                   help="confidence level of the intervals (default 0.95)")
    f.add_argument("--json", action="store_true", help="print the fit as JSON instead of text")
    f.add_argument("-o", "--output", default=None, metavar="FIT.json", help="also save the fit as JSON")

    s = sub.add_parser("settings", help="power (or speed) for a wanted width, with its band")
    s.add_argument("--width", type=number(0, 100, lo_open=True), required=True, metavar="MM", help="wanted width, mm")
    g = s.add_mutually_exclusive_group(required=True)
    g.add_argument("--speed", type=number(0, 1e6, lo_open=True), nargs="+", metavar="MM_MIN",
                   help="speed(s), mm/min: give the power")
    g.add_argument("--power", type=number(0, 1e6, lo_open=True), nargs="+", metavar="MW",
                   help="power(s), mW: give the speed")
    s.add_argument("--fit", required=True, metavar="FIT.json", help="fit saved by 'fit -o'")
    s.add_argument("--model", choices=("dose", "power_law", "empirical"), default=None,
                   help="model to use (default the fit's cross-validated choice)")

    w = sub.add_parser("window", help="draw the process window (width contours, no-cut region)")
    w.add_argument("fit", metavar="FIT.json", help="fit saved by 'fit -o'")
    w.add_argument("-o", "--output", required=True, metavar="WINDOW.png", help="PNG to write")
    w.add_argument("--width", type=number(0, 100, lo_open=True), default=0.2, metavar="MM",
                   help="wanted width to highlight, mm (default 0.2)")
    w.add_argument("--model", choices=("dose", "power_law", "empirical"), default=None,
                   help="model to draw (default the fit's choice)")


    c = sub.add_parser("source", help="the laser's P–I and I–V curves: threshold, slope efficiency, efficiency")
    c.add_argument("csv", metavar="SOURCE.csv", help="current_a, optical_mw and optionally voltage_v per reading")
    c.add_argument("--nominal", type=number(0, 1e7, lo_open=True), default=None, metavar="MW",
                   help="the label's optical power, mW, to compare with the largest measured")
    c.add_argument("-o", "--output", default=None, metavar="CURVES.png", help="draw the curves to a PNG")


def parse_range(text: str, what: str, scale: str = "linear"):
    """``LO:HI:N`` or ``a,b,c`` → values (> 0), as :class:`labkit.errors.InputError` when not.

    >>> parse_range("500:2500:5", "powers").tolist()
    [500.0, 1000.0, 1500.0, 2000.0, 2500.0]
    >>> parse_range("300, 600", "speeds").tolist()
    [300.0, 600.0]
    """
    import numpy as np

    from labkit.errors import InputError
    from labkit.laser.patterns import steps

    try:
        if ":" in text:
            lo, hi, n = text.split(":")
            lo, hi, n = float(lo), float(hi), float(n)
            if not (n >= 1 and n == int(n)):
                raise InputError(f"--{what}: N in LO:HI:N must be a whole number >= 1, got {text!r}")
            values = steps(lo, hi, int(n), scale=scale) if lo > 0 and hi > 0 else np.array([lo, hi])
        else:
            values = np.array([float(t) for t in text.split(",")])
    except ValueError:
        raise InputError(f"--{what}: expected LO:HI:N or a comma list of numbers, got {text!r}") from None
    if not np.all(np.isfinite(values) & (values > 0)):
        raise InputError(f"--{what} must be finite and > 0, got {text!r}")
    return values


def run_cutwidth(args) -> int:
    return {"pattern": _pattern, "measure": _measure, "fit": _fit, "settings": _settings,
            "window": _window, "source": _source}[args.action](args)


def _pattern(args) -> int:
    from labkit.laser.patterns import grid_pattern, write_pattern

    powers = parse_range(args.powers, "powers", args.scale)
    speeds = parse_range(args.speeds, "speeds", args.scale)
    g = grid_pattern(powers, speeds, line_mm=args.line, pitch_mm=args.pitch, overscan_mm=args.overscan,
                     gap_mm=max(6.0, 2 * args.overscan), repeats=args.repeats, passes=args.passes,
                     max_power_mw=args.max_power)
    layout = write_pattern(args.output, g, dialect=args.dialect)
    x0, y0, x1, y1 = g.layout["bounds_mm"]
    print(f"{args.output}: {len(g.layout['lines'])} lines ({len(powers)} powers × {len(speeds)} speeds"
          f" × {args.repeats} repeats), {x1 - x0:.1f} × {y1 - y0:.1f} mm, job time {g.job_time_s():.1f} s")
    print(f"{layout}: layout")
    print(g.legend())
    return 0


def _measure(args) -> int:
    from pathlib import Path

    from labkit._files import atomic_output, check_output_file, figure_format, read_json
    from labkit.errors import InputError
    from labkit.laser.measure import WIDTHS_HEADER, check_layout, measure_lines, register, scale_from_reference
    from labkit.raster.color import to_gray
    from labkit.raster.io import read_image
    from labkit.viz.laser import plot_scan_annotations

    # outputs checked before any work: neither may be an input, nor the other output
    check_output_file(args.output, args.scan, args.layout)
    png = args.annotated or str(Path(args.output).with_suffix(".png"))
    if not args.annotated and Path(png).resolve() == Path(args.scan).resolve():
        png = str(Path(args.output).with_suffix(".annotated.png"))       # never the scan itself
    check_output_file(png, args.scan, args.layout, option="--annotated")
    if Path(png).resolve() == Path(args.output).resolve():
        raise InputError(f"{png}: is also the widths CSV (-o); expected another name for --annotated")
    figure_format(png)
    layout = check_layout(read_json(args.layout, what="layout file"), source=args.layout)
    im = read_image(args.scan)
    img = to_gray(im.pixels) / 255.0
    if args.reference is not None:
        c0, r0, c1, r1, mm = args.reference
        dpi = scale_from_reference((c0, r0), (c1, r1), mm)
    elif args.dpi is not None:
        dpi = args.dpi
    else:
        dpi = im.dpi            # None: the corner crosses' known spacing gives the scale
    import numpy as np

    tf = register(img, layout)
    df = measure_lines(img, layout, dpi=dpi, transform=tf)
    # the transform maps layout (y flipped to rows) to pixels: its rotation is clockwise as seen
    turn = round(-float(np.degrees(tf.rotation)) / 90.0) * 90 % 360
    out = df.assign(material=args.material, thickness_mm=args.thickness, machine=args.machine,
                    beam_mm=args.beam, cut_through="", notes=args.notes or f"measured from {Path(args.scan).name}")
    cols = ["material", "thickness_mm", "machine", "beam_mm", "power_mw", "s_word", "speed_mm_min",
            "width_mm", "cut_through", "repeat", "notes", "row", "col", "width_sd_mm", "burned_fraction", "burned"]
    with atomic_output(args.output, newline="") as fh:
        fh.write(WIDTHS_HEADER + "\n")
        out[cols].to_csv(fh, index=False, float_format="%.6g")
    _save(lambda ax: plot_scan_annotations(img, layout, df, ax, transform=tf), png,
           size=(9, 9 * img.shape[0] / img.shape[1]))
    burned = df.burned.to_numpy()
    w = df.width_mm.to_numpy()[burned]
    print(f"{args.output}: {len(df)} lines at {tf.scale * 25.4:.0f} dpi (registered), {int(burned.sum())} burned"
          + (f", widths {w.min():.3f}…{w.max():.3f} mm" if len(w) else "")
          + f", {int((~burned).sum())} flagged as not burned")
    if turn:
        how = "180° (upside down)" if turn == 180 else f"{turn}° counter-clockwise"
        print(f"{args.scan}: the piece lies turned {how} on the scan (its engraved numbers say so); "
              "every line was measured in its own cell")
    elif not (layout.get("labels") and layout.get("label_mm", 0) > 0):
        print(f"{args.scan}: the layout has no engraved numbers, so the scan's orientation was not checked: "
              "it was taken as upright (row numbers on the left)")
    print(f"{png}: annotated scan")
    return 0


def _save(draw, path, *, size=(7, 5)):
    """Draw on a fresh headless figure and write it (PNG, or the format of the suffix)."""
    import matplotlib

    from labkit._files import write_figure

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=size)
    try:
        draw(ax)
        fig.tight_layout()
        write_figure(fig, path, dpi=120)
    finally:
        plt.close(fig)


def _fit(args) -> int:
    from labkit._files import atomic_output, check_output_file
    from labkit.laser.measure import read_widths
    from labkit.laser.models import fit_report, fit_table

    if args.output:
        check_output_file(args.output, args.csv)

    res = fit_table(read_widths(args.csv), model=args.model, degree=args.degree, level=args.level,
                    source=str(args.csv))
    if args.output:
        with atomic_output(args.output) as fh:
            json.dump(res, fh, indent=1)
    if args.json:
        print(json.dumps(res, indent=1))
        return 0
    print(fit_report(res))
    if args.output:
        print(f"{args.output}: fit saved")
    return 0


def _settings(args) -> int:
    import numpy as np

    from labkit.laser.models import check_width_reach, load_fit, power_band, speed_for_width

    res, fit = load_fit(args.fit, args.model)
    pct = round(100 * fit.level)
    if args.speed is not None:
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            power, lo, hi = (np.atleast_1d(a) for a in power_band(fit, args.width, np.asarray(args.speed)))
        for v, p in zip(args.speed, power):
            check_width_reach(fit, res, args.width, v, float(p) if np.isfinite(p) else None, solve_for="power")
        pmax = res["data"]["power_mw"][1]
        for v, p, a, b in zip(args.speed, power, lo, hi):
            note = "" if np.isfinite(p) and p <= pmax else "  (outside the measured powers)"
            # the power/speed ratio is what M4 holds through the ramps ([CBR40] §IV)
            print(f"width {args.width:g} mm at {v:g} mm/min: power {p:.0f} mW, {pct} % band {a:.0f}…{b:.0f} mW"
                  f" ({fit.model}); P/v = {p / v:.4g} mW per mm/min{note}")
    else:
        for p in args.power:
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                v = float(speed_for_width(fit, args.width, p))
            check_width_reach(fit, res, args.width, p, v if np.isfinite(v) else None, solve_for="speed")
        for p in args.power:
            v = float(speed_for_width(fit, args.width, p))
            print(f"width {args.width:g} mm at {p:g} mW: speed {v:.0f} mm/min ({fit.model})")
    return 0


def _window(args) -> int:
    from labkit._files import check_output_file, figure_format
    from labkit.laser.models import Fit, load_fit
    from labkit.viz.laser import process_window

    check_output_file(args.output, args.fit)
    figure_format(args.output)
    res, fit = load_fit(args.fit, args.model)

    dose = Fit.from_dict(res["models"]["dose"]) if "dose" in res["models"] else None
    _save(lambda ax: process_window(fit, ax, power_range_mw=res["data"]["power_mw"],
                                    speed_range_mm_min=res["data"]["speed_mm_min"], target_mm=args.width,
                                    cut_model=res.get("cut_through"), no_burn_fit=dose), args.output)
    print(f"{args.output}: process window ({fit.model}), {args.width:g} mm contour highlighted")
    return 0


def _source(args) -> int:
    from labkit._files import check_output_file, figure_format
    from labkit.laser.source import fit_source, label_ratio, read_source_csv

    if args.output:
        check_output_file(args.output, args.csv)
        figure_format(args.output)
    df = read_source_csv(args.csv)
    volts = df["voltage_v"].to_numpy() if "voltage_v" in df.columns else None
    f = fit_source(df["current_a"].to_numpy(), df["optical_mw"].to_numpy(), volts)
    pct = round(100 * f.level)
    lo, hi = f.ci["threshold_a"]
    print(f"{args.csv}: {len(df)} readings, largest optical power {f.max_optical_mw:.1f} mW")
    print(f"threshold current {1000 * f.threshold_a:.1f} mA ({pct} % interval {1000 * lo:.1f}…{1000 * hi:.1f})")
    lo, hi = f.ci["slope_w_per_a"]
    print(f"slope efficiency {f.slope_w_per_a:.4f} W/A ({pct} % interval {lo:.4f}…{hi:.4f})")
    if f.series_ohm is not None:
        print(f"above threshold V = {f.v0_v:.3f} V + {f.series_ohm:.3f} Ω × I; "
              f"electrical-to-optical efficiency up to {100 * f.peak_efficiency:.1f} %")
    if args.nominal:
        print(f"largest measured / nominal: {f.max_optical_mw:.1f} / {args.nominal:g} mW = "
              f"{100 * label_ratio(f.max_optical_mw, args.nominal):.1f} %")
    if args.output:
        from labkit.viz.laser import plot_source

        _save(lambda ax: plot_source(df, f, ax), args.output, size=(7, 4.5))
        print(f"{args.output}: P–I and I–V curves")
    return 0
