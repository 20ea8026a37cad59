"""``labkit safety-check``: is the beam off whenever it has to be?

Runs :func:`labkit.machine.safety.run_safety_check` against the virtual
machine (no ``--port``), the firmware's host simulator (``--sim``) or a real
controller (``--port``), prints one line per scenario (PASS, FAIL or NOT
APPLICABLE with what was sent, what the controller reported and what the beam
did) and exits 0 only when every applicable scenario passed. A real port is
driven only after a warning is confirmed (or with ``--yes``).
"""

from __future__ import annotations

import sys

from labkit.commands._args import integer, number


def add_safety_check_arguments(parser):
    from labkit.machine.safety import SCENARIOS

    parser.add_argument("--port", default=None, metavar="PORT_OR_URL",
                        help="a real controller: serial device (/dev/ttyUSB0, COM3) or pyserial URL "
                             "(default: the virtual machine)")
    parser.add_argument("--sim", nargs="?", const=True, default=None, metavar="PATH",
                        help="the firmware's host simulator over a pty (default path "
                             "firmware/build/host/labkit-fw-sim; build it with make -C firmware sim)")
    parser.add_argument("--baud", type=integer(300, 4_000_000), default=None,
                        help="baud rate of --port (default 115200)")
    parser.add_argument("--machine", default=None, metavar="NAME",
                        help="machine description of the virtual machine (default grbl-diode)")
    parser.add_argument("--power", type=number(0, 1e6, lo_open=True), default=None, metavar="S",
                        help="S word of the test cuts, 0 < S <= $30 (default 1 %% of $30: keep it "
                             "low on a real machine)")
    parser.add_argument("--cut-mode", choices=("M4", "M3"), default="M4",
                        help="how the stop scenarios cut (default M4, what labkit writes; GRBL's "
                             "M3 keeps the beam on when its queue runs out)")
    parser.add_argument("--only", action="append", choices=list(SCENARIOS), default=None,
                        metavar="SCENARIO",
                        help="run only this scenario (repeatable): " + ", ".join(SCENARIOS))
    parser.add_argument("--json", action="store_true", help="print the report as JSON")
    parser.add_argument("--yes", action="store_true",
                        help="drive a real port without asking for confirmation")


_WARNING = """\
labkit safety-check is about to drive the controller on {port}.
The head moves {mm:g} mm either way along X from where it is now, at {feed:g} mm/min, and
the laser fires at S{power} ({cut_mode}) during short test cuts; it resets the controller
(which loses its position) and closes and reopens the port. Wear the laser goggles for
your laser's wavelength, close the enclosure, put a non-flammable target under the
head, keep the emergency stop within reach, and stay at the machine.
Type 'yes' to go on: """


def _confirm(args) -> bool:
    from labkit.machine.safety import CUT_FEED_MM_MIN, CUT_MM

    if args.yes:
        return True
    power = f"{args.power:g}" if args.power is not None else " at 1 % of $30"
    print(_WARNING.format(port=args.port, mm=CUT_MM, feed=CUT_FEED_MM_MIN,
                          power=power, cut_mode=args.cut_mode), end="", file=sys.stderr, flush=True)
    if not sys.stdin.isatty():
        print("\nlabkit safety-check: not confirmed (no terminal to ask on; pass --yes to "
              "confirm)", file=sys.stderr)
        return False
    return sys.stdin.readline().strip().lower() == "yes"


def run_safety_check(args) -> int:
    from labkit.errors import InputError
    from labkit.machine.safety import run_safety_check as check

    if args.port is not None and args.sim is not None:
        raise InputError("give --port or --sim, not both")
    from labkit.machine.link import is_virtual_port

    if not is_virtual_port(args.port) and not _confirm(args):
        print("labkit safety-check: nothing was sent", file=sys.stderr)
        return 1
    port = None if is_virtual_port(args.port) else args.port

    def show(result):
        if not args.json:
            print(result.line(), flush=True)

    report = check(port, sim=args.sim, machine=args.machine, s_word=args.power,
                   cut_mode=args.cut_mode, scenarios=args.only, baud=args.baud, progress=show)
    if args.json:
        print(report.to_json())
    else:
        print(report.format().splitlines()[-1])
    return 0 if report.ok else 1
