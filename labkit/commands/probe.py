"""``labkit probe``: the rotating-wire probe of [MicroCAM] ch. 4.

``labkit probe diameter --length MM [--bend DEG] [--stylus-radius MM] [--wire-d MM]``
    the effective diameter D_e the spinning wire's tip sweeps;
``labkit probe calibrate --distance MM --block MM``
    D_e from the contact centres on the two faces of a gauge block;
``labkit probe scan --part circle|square --size MM [--corner MM] [--step MM] [--feed-per-rev MM] …``
    the automated XY scan of a simulated part (acoustic-emission contact detection), the
    profile compensated by D_e / 2 and its error against the true surface; with several
    ``--step`` or ``--feed-per-rev`` values, the error table over all of them.
"""

from __future__ import annotations


def add_probe_arguments(parser):
    from labkit.commands._args import number

    sub = parser.add_subparsers(dest="action", required=True, metavar="ACTION")

    p = sub.add_parser("diameter", help="effective diameter of a bent wire on a spinning stylus")
    p.add_argument("--length", type=number(0, 100, lo_open=True), required=True, metavar="MM",
                   help="wire length beyond the bend L, mm")
    p.add_argument("--bend", type=number(0, 90, lo_open=True), default=45.0, metavar="DEG",
                   help="bend from the spin axis β, 0…90° (default 45, as [MicroCAM])")
    p.add_argument("--stylus-radius", type=number(0, 100), default=0.0, metavar="MM",
                   help="where the wire leaves the stylus, from the spin axis R_s, mm (default 0)")
    p.add_argument("--wire-d", type=number(0, 10), default=0.0, metavar="MM",
                   help="wire diameter d_w, mm (default 0: its centre line; [MicroCAM] used 0.102)")

    p = sub.add_parser("calibrate", help="effective diameter from a gauge block")
    p.add_argument("--distance", type=number(0, 10_000, lo_open=True), required=True, metavar="MM",
                   help="distance between the probe centres at contact on the block's two faces, mm")
    p.add_argument("--block", type=number(0, 10_000, lo_open=True), required=True, metavar="MM",
                   help="gauge block width, mm")

    p = sub.add_parser("scan", help="scan a simulated part and report the reconstruction error")
    p.add_argument("--part", choices=("circle", "square"), default="circle",
                   help="a cylinder, or a square with rounded corners (default circle)")
    p.add_argument("--size", type=number(0.01, 1000), default=12.7, metavar="MM",
                   help="circle diameter or square side, mm (default 12.7: [MicroCAM]'s plug gauge)")
    p.add_argument("--corner", type=number(0, 500), default=2.0, metavar="MM",
                   help="square: corner radius, mm (default 2)")
    p.add_argument("--step", type=number(0.001, 100), nargs="+", default=[0.5], metavar="MM",
                   help="step-over between contacts, mm (default 0.5; several values: a table)")
    p.add_argument("--feed-per-rev", type=number(1e-7, 1), nargs="+", default=[0.001], metavar="MM",
                   help="approach per spindle revolution, the resolution, mm (default 0.001)")
    p.add_argument("--rpm", type=number(1, 1_000_000), default=10_000.0, metavar="RPM",
                   help="spindle speed, rev/min (default 10000)")
    p.add_argument("--de", type=number(0.001, 100), default=1.629, metavar="MM",
                   help="effective diameter D_e, mm (default 1.629, [MicroCAM]'s calibrated probe)")
    p.add_argument("--offset", type=number(0.001, 100), default=0.2, metavar="MM",
                   help="approach start offset R_o from the predicted surface, mm (default 0.2)")
    p.add_argument("--seed", type=int, default=0, help="seed of the signal noise and phases (default 0)")
    p.add_argument("--csv", default=None, metavar="OUT.csv",
                   help="one scan: contact centres and compensated profile; several: the error table")


def run_probe(args) -> int:
    return {"diameter": _diameter, "calibrate": _calibrate, "scan": _scan}[args.action](args)


def _diameter(args) -> int:
    from labkit.micromachining.probe import effective_diameter_mm

    de = effective_diameter_mm(args.length, args.bend, args.stylus_radius, args.wire_d)
    print(f"effective diameter D_e = {de:.6g} mm (reach {de / 2:.6g} mm from the spin axis)")
    return 0


def _calibrate(args) -> int:
    from labkit.micromachining.probe import calibrate_effective_diameter_mm

    de = calibrate_effective_diameter_mm(args.distance, args.block)
    print(f"effective diameter D_e = {de:.6g} mm")
    return 0


def _scan(args) -> int:
    import numpy as np

    from labkit._files import atomic_output
    from labkit.errors import InputError
    from labkit.micromachining.probe import (ProbeSettings, circle_part, fit_circle, profile_error_mm,
                                             rounded_square_part, scan_errors, scan_xy)

    half = args.size / 2
    if args.part == "circle":
        part = circle_part((0.0, 0.0), half)
    else:
        if args.corner > half:
            raise InputError(f"--corner {args.corner:g} mm is more than half the side ({half:g} mm)")
        part = rounded_square_part((0.0, 0.0), args.size, args.corner)
    start = (-(half + args.de / 2 + args.offset + 0.5), 0.0)
    settings = ProbeSettings(effective_diameter_mm=args.de, rpm=args.rpm)
    if len(args.step) == 1 and len(args.feed_per_rev) == 1:
        fpr = args.feed_per_rev[0]
        s = ProbeSettings(effective_diameter_mm=args.de, rpm=args.rpm, feed_mm_min=fpr * args.rpm)
        res = scan_xy(part, start, (1.0, 0.0), s, step_mm=args.step[0], offset_mm=args.offset, seed=args.seed)
        err = profile_error_mm(res.profile, part)
        print(f"{args.part} {args.size:g} mm: {len(res.contacts)} contacts, step-over {args.step[0]:g} mm, "
              f"{1000 * fpr:g} µm per revolution ({s.feed_mm_min:g} mm/min at {args.rpm:g} rev/min)")
        print(f"profile error against the true surface: largest {1000 * np.abs(err).max():.3f} µm, "
              f"mean {1000 * err.mean():+.3f} µm (the probe stops after the touch: inside), "
              f"rms {1000 * np.sqrt((err ** 2).mean()):.3f} µm")
        if args.part == "circle":
            centre, r = fit_circle(res.profile)
            print(f"fitted circle: diameter {2 * r:.5f} mm (true {args.size:g}), "
                  f"centre ({centre[0]:+.5f}, {centre[1]:+.5f}) mm")
        if args.csv:
            data = np.c_[res.contacts, res.profile, err]
            with atomic_output(args.csv) as fh:
                np.savetxt(fh, data, delimiter=",", fmt="%.9g", comments="",
                           header="contact_x_mm,contact_y_mm,profile_x_mm,profile_y_mm,error_mm")
            print(f"{args.csv}: {len(data)} rows")
        return 0
    df = scan_errors(part, start, (1.0, 0.0), step_overs_mm=args.step, feeds_per_rev_mm=args.feed_per_rev,
                     settings=settings, offset_mm=args.offset, seed=args.seed)
    shown = df.assign(**{c.replace("_mm", "_um"): 1000 * df[c] for c in ("max_error_mm", "mean_error_mm",
                                                                         "rms_error_mm")})
    cols = ["step_mm", "feed_per_rev_mm", "contacts", "max_error_um", "mean_error_um", "rms_error_um"]
    print(shown[cols].to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    if args.csv:
        with atomic_output(args.csv, newline="") as fh:
            df.to_csv(fh, index=False)
        print(f"{args.csv}: {len(df)} rows")
    return 0
