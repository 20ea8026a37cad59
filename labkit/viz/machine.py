"""The machine control panel ([LaserApp]'s CNC control manager) and streaming plots.

:class:`ControlPanel` has [LaserApp]'s three states, each enabling only its own
controls: **disconnected** (port list and connect), **manual control**
(status, jog with a step size, home, unlock, set the origin here, a laser test
pulse, console, load / frame / start a job) and **printing** (pause, resume, stop, overrides and the progress bar;
the console is locked). A job runs in a background thread — [LaserApp]'s
communication thread — through :func:`labkit.machine.stream.run_job`, so
every fault ends with the laser off and a report. With no port it drives the
virtual machine.

:func:`plot_rx_fill` draws the RX-buffer use of a virtual machine over time.
"""

from __future__ import annotations

import atexit
import threading
import weakref

__all__ = ["ControlPanel", "plot_rx_fill", "plot_annulus"]

DISCONNECTED, MANUAL, PRINTING = "disconnected", "manual control", "printing"

#: Panels alive in this process: when it exits (a closed notebook kernel), each one's job is
#: cancelled and its machine stopped safely before the port closes.
_PANELS: "weakref.WeakSet" = weakref.WeakSet()


def _close_panels_at_exit() -> None:
    for panel in list(_PANELS):
        try:
            panel.disconnect(reason="the notebook kernel is closing")
        except Exception:                 # one panel's failure must not skip the others
            pass


atexit.register(_close_panels_at_exit)


class ControlPanel:
    """A notebook control panel for one machine.

    Parameters
    ----------
    virtual_options : dict, optional
        Options of the virtual machine used when the port is ``virtual://``
        (e.g. ``{"time_scale": 5}``).

    Attributes
    ----------
    state : str
        ``"disconnected"``, ``"manual control"`` or ``"printing"``.
    machine : Grbl or None
    report : JobReport or None
        The last job's report.
    """

    def __init__(self, *, virtual_options: dict | None = None):
        import ipywidgets as w

        from labkit.machine.link import list_ports, load_config

        self.virtual_options = dict(virtual_options or {"time_scale": 1.0})
        self.machine = None
        self.job = None
        self.report = None
        self.controls = None
        self._thread = None
        cfg = load_config()
        ports = ["virtual://"] + [p.device for p in list_ports()]
        labels = [("virtual machine", "virtual://")] + [(p.label(), p.device) for p in list_ports()]
        self.port = w.Dropdown(options=labels, value=cfg.port if cfg.port in ports else "virtual://",
                               description="port")
        self.connect_button = w.Button(description="connect")
        self.disconnect_button = w.Button(description="disconnect")
        self.status = w.HTML("<b>disconnected</b>")
        self.refresh_button = w.Button(description="status ?")
        self.step = w.Dropdown(options=[0.1, 1.0, 10.0, 50.0], value=10.0, description="step mm")
        self.jog_feed = w.BoundedFloatText(value=3000, min=1, max=20000, description="F mm/min")
        self.jog_buttons = {name: w.Button(description=name, layout=w.Layout(width="60px"))
                            for name in ("X-", "X+", "Y-", "Y+")}
        self.home_button = w.Button(description="home $H")
        self.unlock_button = w.Button(description="unlock $X")
        self.origin_button = w.Button(description="set origin here")
        self.pulse_power = w.BoundedFloatText(value=1.0, min=0.1, max=20.0, step=0.5,
                                              description="pulse % of S max")
        self.pulse_button = w.Button(description="test pulse 0.2 s")
        self.console_line = w.Text(placeholder="G-code or $ command", description="send")
        self.console_button = w.Button(description="send")
        self.console_log = w.Textarea(rows=8, layout=w.Layout(width="100%"), disabled=True)
        self.job_text = w.Textarea(rows=4, placeholder="paste G-code, or set panel.job",
                                   layout=w.Layout(width="100%"))
        self.frame_button = w.Button(description="frame")
        self.start_button = w.Button(description="start")
        self.pause_button = w.Button(description="pause")
        self.resume_button = w.Button(description="resume")
        self.stop_button = w.Button(description="stop", button_style="danger")
        self.feed_up = w.Button(description="feed +10%")
        self.feed_down = w.Button(description="feed −10%")
        self.progress = w.IntProgress(value=0, min=0, max=1, description="job")
        self.progress_text = w.Label("")
        self.connect_button.on_click(lambda _: self.connect())
        self.disconnect_button.on_click(lambda _: self.disconnect())
        self.refresh_button.on_click(lambda _: self.refresh())
        for name, b in self.jog_buttons.items():
            b.on_click(lambda _, n=name: self.jog(n))
        self.home_button.on_click(lambda _: self._run(lambda: self.machine.home()))
        self.unlock_button.on_click(lambda _: self._run(lambda: self.machine.unlock()))
        self.origin_button.on_click(lambda _: self.set_origin())
        self.pulse_button.on_click(lambda _: self.test_pulse())
        self.console_button.on_click(lambda _: self.send(self.console_line.value))
        self.frame_button.on_click(lambda _: self.frame())
        self.start_button.on_click(lambda _: self.start())
        self.pause_button.on_click(lambda _: self.controls and self.controls.pause())
        self.resume_button.on_click(lambda _: self.controls and self.controls.resume())
        self.stop_button.on_click(lambda _: self.controls and self.controls.cancel())
        self.feed_up.on_click(lambda _: self.machine and self.machine.realtime("feed_plus_10"))
        self.feed_down.on_click(lambda _: self.machine and self.machine.realtime("feed_minus_10"))
        self.groups = {
            "connection": [self.port, self.connect_button],
            "manual": [self.disconnect_button, self.refresh_button, self.step, self.jog_feed,
                       *self.jog_buttons.values(), self.home_button, self.unlock_button,
                       self.origin_button, self.pulse_power, self.pulse_button,
                       self.console_line, self.console_button, self.frame_button,
                       self.start_button, self.job_text],
            "printing": [self.pause_button, self.resume_button, self.stop_button, self.feed_up,
                         self.feed_down],
        }
        self.widget = w.VBox([
            w.HBox([self.port, self.connect_button, self.disconnect_button]),
            w.HBox([self.status, self.refresh_button]),
            w.HBox([self.step, self.jog_feed]),
            w.HBox(list(self.jog_buttons.values()) + [self.home_button, self.unlock_button]),
            w.HBox([self.origin_button, self.pulse_power, self.pulse_button]),
            w.HBox([self.console_line, self.console_button]), self.console_log,
            self.job_text,
            w.HBox([self.frame_button, self.start_button, self.pause_button, self.resume_button,
                    self.stop_button, self.feed_up, self.feed_down]),
            w.HBox([self.progress, self.progress_text]),
        ])
        self._set_state(DISCONNECTED)
        _PANELS.add(self)

    def _ipython_display_(self):
        from IPython.display import display

        display(self.widget)

    # -- states -------------------------------------------------------------------------------

    def _set_state(self, state: str) -> None:
        self.state = state
        enabled = {DISCONNECTED: {"connection"}, MANUAL: {"manual"},
                   PRINTING: {"printing"}}[state]
        for group, widgets in self.groups.items():
            for wdg in widgets:
                wdg.disabled = group not in enabled
        if state == DISCONNECTED:
            self.status.value = "<b>disconnected</b>"

    def _log(self, text: str) -> None:
        lines = (self.console_log.value + text + "\n").splitlines()[-200:]
        self.console_log.value = "\n".join(lines) + "\n"

    def _run(self, fn):
        from labkit.errors import LabkitError

        try:
            fn()
        except LabkitError as exc:
            self._log(f"! {exc}")
        self.refresh()

    # -- actions -------------------------------------------------------------------------------

    def connect(self) -> None:
        """Open the chosen port, wait for the banner, read $I and $$."""
        from labkit.errors import LabkitError
        from labkit.machine.grbl import Grbl
        from labkit.machine.link import is_virtual_port, load_config, open_link, save_config

        try:
            link = open_link(self.port.value, virtual_options=self.virtual_options)
            self.machine = Grbl(link)
            self.machine.add_listener(lambda t: None if t.startswith("<") else self._log(f"< {t}"))
            info = self.machine.connect()
        except LabkitError as exc:
            self._log(f"! {exc}")
            if self.machine is not None:
                self.machine.close()
            self.machine = None
            return
        if not is_virtual_port(self.port.value):
            cfg = load_config()
            cfg.port = self.port.value
            save_config(cfg)
        self._log(f"connected: {info.banner} (RX {info.rx_bytes} bytes, planner "
                  f"{info.planner_blocks} blocks)")
        self._set_state(MANUAL)
        self.refresh()

    def disconnect(self, *, reason: str = "disconnected from the panel",
                   wait_s: float = 15.0) -> None:
        """Stop a running job (it ends through its own safe stop), then stop the machine
        (feed hold, soft reset, ``M5 S0``) and close the port; the console log says what
        was sent and confirmed."""
        if self._thread is not None and self._thread.is_alive():
            if self.controls is not None:
                self.controls.cancel(reason)
            self._thread.join(wait_s)
        if self.machine is not None:
            stop = self.machine.stop_safely()
            self._log("safe stop: " + "; ".join(stop.steps))
            self.machine.close()
        self.machine = None
        self._set_state(DISCONNECTED)

    def refresh(self) -> None:
        """Ask for a status report and show it."""
        from labkit.errors import LabkitError

        if self.machine is None:
            return
        try:
            st = self.machine.get_status()
        except LabkitError as exc:
            self._log(f"! {exc}")
            return
        pos = ", ".join(f"{v:.3f}" for v in (st.mpos or ()))
        self.status.value = (f"<b>{st.state}</b> &nbsp; MPos ({pos}) &nbsp; F {st.feed_mm_min or 0:g} "
                             f"&nbsp; S {st.spindle or 0:g} &nbsp; buffer {st.planner_free} blocks, "
                             f"{st.rx_free} bytes free")

    def jog(self, name: str) -> None:
        axis, sign = name[0].lower(), (1 if name[1] == "+" else -1)
        step = sign * float(self.step.value)
        self._run(lambda: self.machine.jog(feed_mm_min=float(self.jog_feed.value), **{axis: step}))

    def set_origin(self) -> None:
        """Make the head's position the job's X/Y zero (``G10 L20 P0 X0 Y0``)."""
        if self.machine is not None and self.state == MANUAL:
            self._log("> set origin (G10 L20 P0 X0 Y0)")
            self._run(lambda: self.machine.set_origin("XY"))

    def test_pulse(self, duration_s: float = 0.2) -> None:
        """Fire the beam briefly at the chosen share of ``$30`` where the head is."""
        if self.machine is None or self.state != MANUAL:
            return
        s = float(self.pulse_power.value) / 100.0 * self.machine.setting(30, 1000.0)
        self._log(f"> test pulse S{s:g} for {duration_s:g} s")
        self._run(lambda: self.machine.test_pulse(s, duration_s))

    def send(self, line: str) -> None:
        """Console: send one line (send-response) and log the replies."""
        line = line.strip()
        if not line or self.machine is None or self.state != MANUAL:
            return
        self._log(f"> {line}")
        self._run(lambda: self.machine.command(line))

    def load(self, text: str, *, machine: str = "grbl-diode") -> None:
        from labkit.machine.stream import Job

        self.job_text.value = text
        self.job = Job.from_text(text, machine=machine)
        self.progress.max = max(1, len(self.job.source_lines))
        self.progress.value = 0

    def frame(self) -> None:
        """Trace the job's bounding box with the beam off."""
        from labkit.machine.stream import frame_text

        if self.job is None and self.job_text.value.strip():
            self.load(self.job_text.value)
        if self.job is None:
            return
        for line in frame_text(self.job):
            self.send(line)

    def start(self, *, wait: bool = False, **options) -> None:
        """Run the loaded job in a background thread (``wait=True``: until it ends)."""
        from labkit.machine.stream import Controls, run_job

        if self.job is None and self.job_text.value.strip():
            self.load(self.job_text.value)
        if self.job is None or self.machine is None:
            return
        self.controls = Controls()
        self._set_state(PRINTING)

        def progress(executed, acked, total, eta_s):
            self.progress.value = acked
            self.progress_text.value = f"line {acked}/{total}, done {executed}, ETA {eta_s:.0f} s"

        def work():
            # run_job stops the machine on every end (in this thread signals are the kernel's:
            # an interrupt does not reach it; the stop button, disconnect and the kernel's exit
            # cancel it instead)
            try:
                self.report = run_job(self.machine, self.job, progress=progress,
                                      controls=self.controls, **options)
                self._log(self.report.summary())
            finally:
                if self.machine is not None:
                    self._set_state(MANUAL)
                    self.refresh()

        self._thread = threading.Thread(target=work, name="labkit-job", daemon=True)
        self._thread.start()
        if wait:
            self._thread.join()


def plot_rx_fill(vm, ax=None, *, rx_bytes: int = 128, label: str | None = None):
    """RX-buffer use of a :class:`~labkit.machine.virtual.VirtualMachine` over simulated time."""
    import matplotlib.pyplot as plt
    import numpy as np

    if ax is None:
        _, ax = plt.subplots(figsize=(7, 2.6))
    data = np.array(vm.rx_fill) if vm.rx_fill else np.zeros((0, 2))
    ax.step(data[:, 0], data[:, 1], where="post", lw=0.8, label=label)
    ax.axhline(rx_bytes - 1, color="k", lw=0.6, ls=":")
    ax.set_xlabel("machine time (s)")
    ax.set_ylabel("RX bytes used")
    ax.set_ylim(0, rx_bytes + 4)
    return ax


def plot_annulus(moves=None, ax=None, *, origin=None, reach=None):
    """The Dobot's reachable annulus, the canvas origin, and a job drawn in arm coordinates."""
    import matplotlib.pyplot as plt
    import numpy as np

    from labkit.gcode.arcs import moves_polylines
    from labkit.machine.dobot import ORIGIN_MM, REACH_MM, canvas_to_robot

    origin = origin or ORIGIN_MM
    reach = reach or REACH_MM
    if ax is None:
        _, ax = plt.subplots(figsize=(5, 5))
    t = np.linspace(0, 2 * np.pi, 361)
    for r in reach:
        ax.plot(r * np.cos(t), r * np.sin(t), "k-", lw=0.8)
    ax.plot([0], [0], "ks")
    ax.annotate("base", (0, 0), textcoords="offset points", xytext=(6, 6))
    ax.plot([origin[0]], [origin[1]], "r+", ms=12)
    ax.annotate("canvas origin", origin, textcoords="offset points", xytext=(6, -12), color="r")
    if moves is not None:
        for poly, burn in zip(moves_polylines(moves, tol_mm=0.05), moves.laser_on):
            X, Y = canvas_to_robot(poly[:, 0], poly[:, 1], origin)
            ax.plot(X, Y, "r-" if burn else "b:", lw=1.0 if burn else 0.6)
    ax.set_aspect("equal")
    ax.set_xlabel("arm X (mm)")
    ax.set_ylabel("arm Y (mm)")
    return ax
