"""``labkit ports``, ``labkit stream`` and ``labkit console``: machines from the shell.

``labkit ports`` lists serial ports with what each looks like (CH340, FTDI,
CP210x, STM32 VCP, Arduino). ``labkit stream FILE`` sends a job — to the
virtual machine when no ``--port`` is given — with a progress bar and a
summary, and exits non-zero on any fault. ``labkit console`` sends lines one
by one and prints every reply (``?`` ``!`` ``~`` and ``ctrl-x`` are sent as
real-time bytes).
"""

from __future__ import annotations

import sys

from labkit.commands._args import integer, number


def _add_connection(parser):
    parser.add_argument("--port", default=None, metavar="PORT_OR_URL",
                        help="serial device (/dev/ttyUSB0, COM3), pyserial URL (socket://host:port, "
                             "rfc2217://…), 'virtual://', or 'last' for the port used last time "
                             "(default: the virtual machine)")
    parser.add_argument("--baud", type=integer(300, 4_000_000), default=None,
                        help="baud rate (default 115200)")
    parser.add_argument("--protocol", choices=("grbl", "labkit-fw", "dobot"), default=None,
                        help="what the machine speaks (default grbl)")
    parser.add_argument("--virtual-speed", type=number(0, 1e6), default=0.0, metavar="X",
                        help="virtual machine only: simulated seconds per real second "
                             "(0, the default: as fast as possible)")
    parser.add_argument("--machine", default=None, metavar="NAME",
                        help="machine description for the virtual machine and the ETA "
                             "(default grbl-diode)")


def _settings(args):
    from labkit.machine.link import DEFAULT_BAUD, load_config

    cfg = load_config()
    port = args.port
    if port == "last":
        port = cfg.port
    protocol = args.protocol or (cfg.protocol if args.port == "last" else "grbl")
    baud = args.baud or (cfg.baud if args.port == "last" else DEFAULT_BAUD)
    return port, baud, protocol, cfg


def _connect(args, transcript=None):
    from labkit.machine.link import is_virtual_port, open_link, save_config

    port, baud, protocol, cfg = _settings(args)
    opts = {"time_scale": args.virtual_speed, "tick_s": 0.05}
    if args.machine:
        opts["machine"] = args.machine
    link = open_link(port, baud, virtual_options=opts)
    if protocol == "labkit-fw":
        from labkit.machine.labkitfw import LabkitFirmware as cls
    else:
        from labkit.machine.grbl import Grbl as cls
    machine = cls(link, transcript=transcript)
    try:
        machine.connect()
    except BaseException:
        machine.close()
        raise
    if not is_virtual_port(port) and not port.startswith("loop://"):     # a device to remember
        cfg.port, cfg.baud, cfg.protocol = port, baud, protocol
        if args.machine:
            cfg.machine = args.machine
        save_config(cfg)
    return machine


# -- ports ------------------------------------------------------------------------------------

def add_ports_arguments(parser):
    parser.add_argument("--all", action="store_true", help="also ports without USB ids")


def run_ports(args) -> int:
    from labkit.machine.link import list_ports

    ports = [p for p in list_ports() if args.all or p.vid_pid]
    if not ports:
        print("no USB serial ports found (plug the board in; 'labkit ports --all' lists every "
              "serial port; 'labkit stream FILE' without --port uses the virtual machine)")
        return 0
    for p in ports:
        print(p.label())
    return 0


# -- stream -----------------------------------------------------------------------------------

def add_stream_arguments(parser):
    parser.add_argument("file", help="G-code job")
    _add_connection(parser)
    parser.add_argument("--mode", choices=("counting", "send-response"), default="counting",
                        help="character counting (fills GRBL's RX buffer; default) or one line "
                             "at a time")
    parser.add_argument("--check-first", action="store_true",
                        help="run the whole job in GRBL's check mode ($C) first")
    parser.add_argument("--resume-from", type=integer(1, None), default=None, metavar="LINE",
                        help="start at this source line, with its modal state rebuilt and the "
                             "laser off on the way there")
    parser.add_argument("--on-error", choices=("stop", "skip"), default="stop",
                        help="error:N stops the job safely (default) or is reported and skipped")
    parser.add_argument("--log", default=None, metavar="TRANSCRIPT",
                        help="write every line sent and reply received, with times")
    parser.add_argument("--dialect", choices=("grbl", "labkit-fw"), default=None,
                        help="how the file is read (default: the protocol's)")
    parser.add_argument("--allow-spindle-mode", action="store_true",
                        help="stream a burning job even when the machine's $32 is 0 (a warning)")
    parser.add_argument("--no-preflight", action="store_true",
                        help="skip the check of the job against the controller ($G, $#, $30, "
                             "travel) before the first line; the controller's own limits still "
                             "apply")
    parser.add_argument("--s-max", type=number(0, 1e9, lo_open=True), default=None, metavar="S",
                        help="Dobot only: the S of full laser power, 100 %% PWM duty (default: "
                             "the dialect's, GRBL 1000, labkit-fw 255); a higher S is refused")
    from labkit.record import add_record_option

    add_record_option(parser, default_on=True)


class _Progress:
    """tqdm's bar on stderr in a terminal (nothing when stderr is not a terminal: ``disable=None``);
    without tqdm, a line every few seconds."""

    def __init__(self, total: int):
        self.total = total
        self.bar = None
        self.last = 0.0
        try:
            from tqdm import tqdm

            self.bar = tqdm(total=total, unit="line", file=sys.stderr, disable=None)
        except ImportError:
            pass

    def __call__(self, executed, acked, total, eta_s):
        if self.bar is not None:
            self.bar.n = acked
            self.bar.set_postfix_str(f"executed {executed}, ETA {eta_s:.0f} s", refresh=True)
            return
        import time

        now = time.monotonic()
        if sys.stderr.isatty() and now - self.last > 2:
            self.last = now
            print(f"\rline {acked}/{total} sent, {executed} done, ETA {eta_s:.0f} s",
                  end="", file=sys.stderr)

    def close(self):
        if self.bar is not None:
            self.bar.close()


def run_stream(args) -> int:
    from labkit._files import check_input_file, check_output_file

    check_input_file(args.file, what="G-code job")
    if args.log:
        check_output_file(args.log, args.file)
    port, baud, protocol, cfg = _settings(args)
    if protocol == "dobot":
        from labkit.commands.dobot import run_dobot_stream

        return run_dobot_stream(args, port, baud)
    if args.s_max is not None:
        from labkit.errors import InputError

        raise InputError("--s-max is for --protocol dobot; GRBL's full power is its $30 setting")
    from labkit.machine.stream import Job, run_job

    dialect = args.dialect or ("labkit-fw" if protocol == "labkit-fw" else "grbl")
    from labkit.machine.link import is_virtual_port

    job = Job.from_file(args.file, dialect=dialect, machine=args.machine or "grbl-diode",
                        virtual_machine=is_virtual_port(port))
    from labkit.record import stream_record_target, utc_now

    started = utc_now()
    record_path = stream_record_target(args, started)      # checked before the first byte
    log = _open_transcript(args.log)         # before the first byte goes out
    try:
        machine = _connect(args, transcript=log)
        progress = _Progress(len(job.source_lines))
        try:
            report = run_job(machine, job, mode=args.mode, on_error=args.on_error,
                             check_first=args.check_first, resume_from=args.resume_from,
                             progress=progress, allow_spindle_mode=args.allow_spindle_mode,
                             machine=args.machine, preflight=not args.no_preflight)
        finally:
            progress.close()
            machine.close()
        text = report.summary(command=_stream_command(args))
        if log is not None:
            for line in text.splitlines():
                log.append((log[-1][0] if log else 0.0, "#", line))
    finally:
        if log is not None:
            log.fh.close()
    print(text)
    if record_path is not None:
        from labkit.record import stream_record, write_record

        write_record(stream_record(args, report, started=started, ended=utc_now(),
                                   machine_name=args.machine or "grbl-diode", command=_stream_command(args)),
                     record_path)
        print(f"record: {record_path}")
    return 0 if report.ok else 1


def _open_transcript(path):
    """The ``--log`` file, opened (and so checked) before anything is sent; every line is
    written and flushed as it happens, so the transcript survives any end of the stream."""
    if not path:
        return None
    import time

    from labkit.errors import InputError
    from labkit.machine.grbl import Transcript

    try:
        fh = open(path, "w", encoding="utf-8")
        fh.write(f"# labkit stream transcript, {time.strftime('%Y-%m-%d %H:%M:%S')}: seconds, "
                 f"> sent, < received, # labkit's notes\n")
        fh.flush()                           # a full disk shows here, not after the job
    except OSError as exc:
        raise InputError(f"--log {path}: cannot write the transcript there ({exc.strerror}); "
                         f"nothing was sent") from None
    return Transcript(fh)


def _stream_command(args) -> list:
    """The command line that runs this job again, for the resume advice (``--resume-from``
    is added by the report)."""
    cmd = ["labkit", "stream", args.file]
    for flag, value in (("--port", args.port), ("--baud", args.baud),
                        ("--protocol", args.protocol), ("--machine", args.machine),
                        ("--dialect", args.dialect)):
        if value is not None:
            cmd += [flag, str(value)]
    if args.virtual_speed:
        cmd += ["--virtual-speed", f"{args.virtual_speed:g}"]
    if args.mode != "counting":
        cmd += ["--mode", args.mode]
    if args.on_error != "stop":
        cmd += ["--on-error", args.on_error]
    if args.allow_spindle_mode:
        cmd.append("--allow-spindle-mode")
    if args.no_preflight:
        cmd.append("--no-preflight")
    if args.log:
        cmd += ["--log", args.log + ".resume"]
    return cmd


# -- console ------------------------------------------------------------------------------------

def add_console_arguments(parser):
    _add_connection(parser)


_REALTIME_WORDS = {"?": "status", "!": "feed_hold", "~": "cycle_start", "ctrl-x": "soft_reset",
                   "reset": "soft_reset", "jog-cancel": "jog_cancel"}


class _ConsoleInterrupted(Exception):
    """SIGINT or SIGTERM in the console: leave the input loop for the safe stop."""


def run_console(args) -> int:
    """Every end of the console — quit, end of input, Ctrl-C, SIGTERM, a lost link, an
    error — stops the machine (feed hold, soft reset, M5 S0) before the port closes, and
    prints what was sent and what was confirmed.

    Each typed line is read first by :class:`labkit.gcode.Interpreter` (the modal state
    kept from line to line, as the controller keeps it): a line it rejects is explained
    (column, what was expected) and sent all the same, so the controller's own answer is
    the one that counts."""
    import time

    from labkit.errors import LabkitError, MachineError
    from labkit.gcode import Interpreter
    from labkit.machine.labkitfw import LabkitFirmware
    from labkit.machine.stream import StopSignals

    def interrupted(name):
        raise _ConsoleInterrupted(name)

    machine = _connect(args)
    machine.log_status = True
    print(f"connected: {machine.info.banner} (RX {machine.info.rx_bytes} bytes, planner "
          f"{machine.info.planner_blocks} blocks). '?' status, '!' hold, '~' resume, 'ctrl-x' "
          f"reset, 'quit' to leave (the machine is stopped and the laser switched off first).")
    machine.add_listener(lambda text: print(f"< {text}"))
    reader = Interpreter("labkit-fw" if isinstance(machine, LabkitFirmware) else "grbl")
    typed = 0
    code = 0
    with StopSignals(interrupted) as signals:
        try:
            for raw in sys.stdin:
                line = raw.strip()
                if line in ("quit", "exit"):
                    break
                if not line:
                    continue
                if line in _REALTIME_WORDS:
                    machine.realtime(_REALTIME_WORDS[line])
                else:
                    typed += 1
                    _, error = reader.feed(line)
                    if error is not None:
                        error.filename, error.line = "<console>", typed
                        print(f"labkit reads it as {error.format()}; sent all the same")
                    machine.send_line(line)
                time.sleep(0.15)
                machine.drain_events()
                if machine.disconnected or machine.link.lost:
                    raise MachineError(machine.disconnected or machine.link.lost)
        except _ConsoleInterrupted as exc:
            print(f"interrupted by {exc}: stopping the machine", file=sys.stderr)
            code = 1
        except LabkitError as exc:
            print(f"labkit console: {exc}", file=sys.stderr)
            code = 1
        finally:
            signals.stopping()
            stop = machine.stop_safely()
            machine.close()
            print("safe stop: " + "; ".join(stop.steps), file=sys.stderr)
    return code
