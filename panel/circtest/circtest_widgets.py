"""The circtest panel's Qt part: it shows what circtest_logic and circtest_live give it.
Every program runs in a QProcess (the GUI thread only receives its output); LinuxCNC's status
is polled by a timer, never waited on; its error channel is never read."""
import math
import os
import tempfile

from PyQt5.QtCore import QObject, QPointF, QProcess, Qt, QTimer, pyqtSignal
from PyQt5.QtGui import QColor, QImage, QPainter, QPen, QPolygonF
from PyQt5.QtSvg import QSvgWidget
from PyQt5.QtWidgets import (QCheckBox, QDoubleSpinBox, QFormLayout, QHBoxLayout, QLabel,
                             QLineEdit, QListWidget, QMessageBox, QPlainTextEdit, QPushButton,
                             QTableWidget, QTableWidgetItem, QTabWidget, QVBoxLayout, QWidget)

import circtest_live as live
import circtest_logic as logic
import circtest_pages as pages
import circtest_records as records

RUN_COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf")


class ProgramRunner(QObject):
    """One program in a QProcess: `line` for each line it prints, then `done` with its stdout
    or `failed` with its one-line error."""

    line = pyqtSignal(str)
    done = pyqtSignal(str)
    failed = pyqtSignal(str)

    def __init__(self, argv, parent=None):
        super().__init__(parent)
        self.argv = argv
        self.stdout = ""
        self.stderr = ""
        self._pending = ""
        self.process = QProcess(self)
        self.process.readyReadStandardOutput.connect(self._read_stdout)
        self.process.readyReadStandardError.connect(self._read_stderr)
        self.process.finished.connect(self._finished)
        self.process.errorOccurred.connect(self._error)

    def start(self):
        self.process.start(self.argv[0], self.argv[1:])

    def _read_stdout(self):
        text = bytes(self.process.readAllStandardOutput()).decode("utf-8", "replace")
        self.stdout += text
        self._pending += text
        *lines, self._pending = self._pending.split("\n")
        for line in lines:
            self.line.emit(line)

    def _read_stderr(self):
        self.stderr += bytes(self.process.readAllStandardError()).decode("utf-8", "replace")

    def _finished(self, exit_code, exit_status):
        self._read_stdout()
        self._read_stderr()
        if exit_status == QProcess.CrashExit:
            exit_code = -15
        try:
            self.done.emit(logic.finish(self.argv, exit_code, self.stdout, self.stderr))
        except logic.ProgramError as exc:
            self.failed.emit(exc.message)

    def _error(self, error):
        if error == QProcess.FailedToStart:
            self.failed.emit("%s: could not be started" % self.argv[0])


class PolarPlot(QWidget):
    """The live plot: the nominal circle, rings every `um_per_division` µm (fixed, so two runs
    compare), each run's lowest and highest deviation per angle bin. The grid and the finished
    runs are drawn once into a cached image; a frame draws only the run in progress."""

    DIVISIONS = 4  # rings inside and outside the nominal circle

    def __init__(self, parent=None):
        super().__init__(parent)
        self.polar = None
        self.um_per_division = logic.DEFAULT_UM_PER_DIVISION
        self._cache = None
        self._cache_key = None
        self._cached_runs = 0
        self._unit = []
        self.setMinimumSize(240, 240)

    def set_polar(self, polar):
        self.polar = polar
        self.update()

    def set_scale(self, um_per_division):
        self.um_per_division = um_per_division
        self._cache_key = None
        self.update()

    def _geometry(self):
        cx, cy = self.width() / 2.0, self.height() / 2.0
        outer = 0.45 * min(self.width(), self.height())
        division_px = outer / (2.0 * self.DIVISIONS)
        return cx, cy, outer / 2.0, division_px

    def _run_lines(self, run, colour):
        """The run's two polylines (lowest, highest per bin) with their pen."""
        cx, cy, nominal_px, division_px = self._geometry()
        px_per_um = division_px / self.um_per_division
        if len(self._unit) != self.polar.bins:
            step = 2.0 * math.pi / self.polar.bins
            self._unit = [(math.cos((k + 0.5) * step), math.sin((k + 0.5) * step))
                          for k in range(self.polar.bins)]
        lines = []
        for values in (run.low_um, run.high_um):
            line = QPolygonF()
            for (c, s), dev in zip(self._unit, values):
                if dev != math.inf and dev != -math.inf:
                    r = max(0.0, nominal_px + dev * px_per_um)
                    line.append(QPointF(cx + r * c, cy - r * s))
            lines.append(line)
        return QPen(QColor(colour), 1.2), lines

    def _background(self):
        """The grid and the finished runs: a run is drawn into it once, when it finishes."""
        finished = len(self.polar.runs) - 1 if self.polar and self.polar.runs else 0
        key = (self.width(), self.height(), self.um_per_division, id(self.polar))
        if key != self._cache_key or finished < self._cached_runs:
            self._cache = self._grid()
            self._cache_key, self._cached_runs = key, 0
        if finished > self._cached_runs:
            painter = QPainter(self._cache)
            painter.setRenderHint(QPainter.Antialiasing)
            for i in range(self._cached_runs, finished):
                pen, lines = self._run_lines(self.polar.runs[i],
                                             RUN_COLOURS[i % len(RUN_COLOURS)])
                painter.setPen(pen)
                for line in lines:
                    painter.drawPolyline(line)
            painter.end()
            self._cached_runs = finished
        return self._cache

    def _grid(self):
        image = QImage(self.size(), QImage.Format_RGB32)
        image.fill(QColor("white"))
        painter = QPainter(image)
        painter.setRenderHint(QPainter.Antialiasing)
        cx, cy, nominal_px, division_px = self._geometry()
        grid = QPen(QColor("#c0c0c0"))
        for k in range(-self.DIVISIONS + 1, self.DIVISIONS + 1):
            painter.setPen(QPen(QColor("#606060"), 1.5) if k == 0 else grid)
            r = nominal_px + k * division_px
            painter.drawEllipse(QPointF(cx, cy), r, r)
        painter.setPen(QColor("black"))
        painter.drawText(6, 16, "%g µm/div" % self.um_per_division)
        painter.end()
        return image

    def paintEvent(self, _event):
        painter = QPainter(self)
        painter.drawImage(0, 0, self._background())
        if self.polar is None or not self.polar.runs:
            return
        # The run in progress without antialiasing (a third of the cost); it is redrawn
        # smooth into the cached image once the next run starts.
        i = len(self.polar.runs) - 1
        run = self.polar.runs[i]
        pen, lines = self._run_lines(run, RUN_COLOURS[i % len(RUN_COLOURS)])
        painter.setPen(pen)
        for line in lines:
            painter.drawPolyline(line)
        if run.last:
            cx, cy, nominal_px, division_px = self._geometry()
            angle, dev = run.last
            r = max(0.0, nominal_px + dev * division_px / self.um_per_division)
            painter.setBrush(QColor("black"))
            painter.drawEllipse(QPointF(cx + r * math.cos(angle), cy - r * math.sin(angle)), 3, 3)


class PathPreview(QWidget):
    """The nominal path in the plane, from circgen's program header, before anything moves."""

    def __init__(self, parent=None):
        super().__init__(parent)
        self.points = []
        self.setMinimumSize(160, 160)

    def set_points(self, points):
        self.points = points
        self.update()

    def paintEvent(self, _event):
        painter = QPainter(self)
        painter.setRenderHint(QPainter.Antialiasing)
        painter.fillRect(self.rect(), QColor("white"))
        if not self.points:
            painter.drawText(self.rect(), Qt.AlignCenter, "Preview: the path appears here")
            return
        xs = [p[0] for p in self.points]
        ys = [p[1] for p in self.points]
        span = max(max(xs) - min(xs), max(ys) - min(ys), 1e-9)
        scale = 0.85 * min(self.width(), self.height()) / span
        mx, my = (max(xs) + min(xs)) / 2.0, (max(ys) + min(ys)) / 2.0
        line = QPolygonF([QPointF(self.width() / 2.0 + (x - mx) * scale,
                                  self.height() / 2.0 - (y - my) * scale) for x, y in self.points])
        painter.setPen(QPen(QColor("#1f77b4"), 2))
        painter.drawPolyline(line)
        painter.setBrush(QColor("#2ca02c"))
        painter.drawEllipse(line[0], 4, 4)


class CircTestPanel(QWidget):
    """The steps: set up, run, results, compensation, report, history. `status` shows the one
    line of the last thing that happened (a program's error as it printed it; any other error
    as one line too, never only a traceback on stderr)."""

    def __init__(self, programs=None, linuxcnc_module=None, ini="", parent=None):
        super().__init__(parent)
        self.programs = programs or logic.Programs(logic.find_programs())
        self.linuxcnc = linuxcnc_module
        self.runners = []
        self.session_dir = None
        self.session_running = False
        self.source = None
        self.traces = self.RUN_TRACES
        self.scratch = tempfile.TemporaryDirectory(prefix="circtest-panel-")  # the preview
        self.tabs = QTabWidget()
        self.status = QLabel("")
        self.status.setWordWrap(True)
        self.machine = QLabel("")
        layout = QVBoxLayout(self)
        layout.addWidget(self.machine)
        layout.addWidget(self.tabs)
        layout.addWidget(self.status)
        self._build_setup(ini)
        self._build_run()
        self._build_results()
        self._build_compensation()
        self.report_page = pages.ReportPage(self)
        self.report_button = self.report_page.open_button
        self.tabs.addTab(self.report_page, "Report")
        self.history_page = pages.HistoryPage(self)
        self.tabs.addTab(self.history_page, "History")
        if os.path.isfile(self.ini_edit.text().strip()):
            self.history_page.refresh()  # the INI's machine, before any test
        self.live_timer = QTimer(self)
        self.live_timer.setInterval(100)  # 10 frames/s
        self.live_timer.timeout.connect(self.poll_live)
        self.machine_timer = QTimer(self)
        self.machine_timer.setInterval(1000)
        self.machine_timer.timeout.connect(self.poll_machine)
        self.machine_timer.start()
        self.poll_machine()

    # ---- building ----------------------------------------------------------------------------

    def _build_setup(self, ini):
        page = QWidget()
        form = QFormLayout()
        self.ini_edit = QLineEdit(ini or os.environ.get("INI_FILE_NAME", ""))
        form.addRow("Machine INI", self.ini_edit)
        planes = QHBoxLayout()
        self.plane_boxes = {p: QCheckBox(p) for p in logic.PLANES}
        self.plane_boxes["XY"].setChecked(True)
        for box in self.plane_boxes.values():
            planes.addWidget(box)
        form.addRow("Planes", planes)
        self.diameter = QDoubleSpinBox()
        self.diameter.setRange(1.0, 2000.0)
        self.diameter.setValue(logic.DEFAULT_DIAMETER_MM)
        self.diameter.setSuffix(" mm")
        form.addRow("Diameter", self.diameter)
        self.feeds = QLineEdit("%g" % logic.DEFAULT_FEED_MM_PER_MIN)
        form.addRow("Feed(s), mm/min", self.feeds)
        self.annex_c = QLineEdit("")
        self.annex_c.setPlaceholderText("D2,V2: the feed of Annex C from a reference test "
                                        "(circgen --ref-d/--ref-f; Preview sets the feed)")
        form.addRow("Annex C reference", self.annex_c)
        self.start_box = QCheckBox("The panel presses cycle start (simulators, unattended cells)")
        form.addRow("", self.start_box)
        self.preview_button = QPushButton("Preview (circgen checks the machine's limits)")
        self.preview_button.clicked.connect(self.preview)
        self.preview = PathPreview()
        box = QVBoxLayout(page)
        box.addLayout(form)
        box.addWidget(self.preview_button)
        box.addWidget(self.preview, 1)
        self.tabs.addTab(page, "Set up")

    def _build_run(self):
        page = QWidget()
        self.run_button = QPushButton("Run the test")
        self.run_button.clicked.connect(self.run_test)
        self.verify_button = QPushButton("Verify (after the restart)")
        self.verify_button.clicked.connect(self.verify)
        self.scale = QDoubleSpinBox()
        self.scale.setRange(0.1, 1000.0)
        self.scale.setValue(logic.DEFAULT_UM_PER_DIVISION)
        self.scale.setSuffix(" µm/div")
        self.plot = PolarPlot()
        self.scale.valueChanged.connect(self.plot.set_scale)
        self.run_label = QLabel("")
        self.log = QPlainTextEdit()
        self.log.setReadOnly(True)
        self.log.setMaximumBlockCount(2000)
        buttons = QHBoxLayout()
        for w in (self.run_button, self.verify_button, self.scale, self.run_label):
            buttons.addWidget(w)
        box = QVBoxLayout(page)
        box.addLayout(buttons)
        box.addWidget(self.plot, 3)
        box.addWidget(self.log, 1)
        self.tabs.addTab(page, "Run")

    def _build_results(self):
        page = QWidget()
        self.results = QTableWidget(0, 10)
        self.results.setHorizontalHeaderLabels(
            ["Test", "Plane", "Direction", "Feed mm/min", "G µm", "U(G) µm", "F µm", "U(F) µm",
             "H µm", "U(H) µm"])
        self.sources = QTableWidget(0, 3)
        self.sources.setHorizontalHeaderLabels(["Source", "G µm", "Share of G %"])
        box = QVBoxLayout(page)
        box.addWidget(QLabel("circana analyze (results.json; verify-results.json after Verify)"))
        box.addWidget(self.results)
        box.addWidget(QLabel("circana diagnose (diagnosis.json)"))
        box.addWidget(self.sources)
        # circana's own plot of the runs (plot.svg, as in the report)
        self.svg = QSvgWidget()
        self.svg.setMinimumHeight(240)
        box.addWidget(self.svg, 1)
        self.tabs.addTab(page, "Results")

    def _build_compensation(self):
        page = QWidget()
        self.plan_list = QListWidget()
        self.diff = QPlainTextEdit()
        self.diff.setReadOnly(True)
        self.apply_button = QPushButton("Apply the corrections…")
        self.apply_button.setEnabled(False)
        self.apply_button.clicked.connect(self.apply)
        box = QVBoxLayout(page)
        box.addWidget(QLabel("circcomp plan"))
        box.addWidget(self.plan_list, 1)
        box.addWidget(self.diff, 1)
        box.addWidget(self.apply_button)
        self.tabs.addTab(page, "Compensation")

    # ---- running programs --------------------------------------------------------------------

    def say(self, text):
        self.status.setText(text)

    def launch(self, argv, on_done, on_line=None, on_failed=None, on_error=None):
        """Starts ARGV in the background. Its failure, or an error in showing what it gave, is
        said in one line: to ON_ERROR when given (a step's own line), else on the status line
        (and the run buttons are usable again)."""
        runner = ProgramRunner(argv, self)
        self.runners.append(runner)

        def forget():
            if runner in self.runners:
                self.runners.remove(runner)

        def failed(line):
            forget()
            if on_error:
                on_error(line)
                return
            self.say(line)
            self._idle()
            if on_failed:
                on_failed()

        def done(out):
            forget()
            try:
                on_done(out)
            except Exception as exc:  # noqa: BLE001 (shown as one line, never a traceback)
                (on_error or self.say)(records.error_line(exc))

        runner.done.connect(done)
        runner.failed.connect(failed)
        if on_line:
            runner.line.connect(on_line)
        runner.start()
        return runner

    def setup(self):
        planes = [p for p, box in self.plane_boxes.items() if box.isChecked()]
        s = logic.Setup(self.ini_edit.text().strip(), planes, self.diameter.value(),
                        logic.parse_feeds(self.feeds.text()), self.start_box.isChecked())
        s.check()
        return s

    def preview_setup(self):
        """The set-up with Annex C's reference when one is given (circgen computes the feed)."""
        s = self.setup()
        text = self.annex_c.text().strip()
        if text:
            values = logic.parse_feeds(text)
            if len(values) != 2 or not all(math.isfinite(v) and v > 0 for v in values):
                raise logic.ProgramError("circtest panel: error: Annex C reference: expected "
                                         "D2,V2 (mm, mm/min), got '%s'" % text, 2)
            s.annex_c = tuple(values)
        return s

    def _guarded(self, action):
        try:
            action()
        except Exception as exc:  # noqa: BLE001 (shown as one line, never a traceback)
            self.say(records.error_line(exc))
            self._idle()

    def _idle(self):
        self.run_button.setEnabled(True)
        self.verify_button.setEnabled(True)

    def preview(self):
        def go():
            out = os.path.join(self.scratch.name, "preview.ngc")
            self.launch(logic.circgen_command(self.programs, self.preview_setup(), out),
                        lambda _out: self._show_preview(out))
        self._guarded(go)

    def _show_preview(self, program):
        header = logic.program_header(program)
        self.preview.set_points(logic.preview_path(header))
        # The feed(s) circgen wrote (Annex C's when a reference was given) go to circtest run.
        self.feeds.setText(",".join("%g" % f for f in logic.program_feeds(header)))
        self.say("circgen: the program is within the machine's limits (%s)" % program)

    # The traces a recording writes in the session folder: a live output while it records
    # (when the recorder has one), the trace when it is complete.
    RUN_TRACES = ("live.csv", "trace.csv")
    VERIFY_TRACES = ("verify-live.csv", "verify-trace.csv")

    def run_test(self):
        self._start_session(logic.circtest_run_command, self.RUN_TRACES)

    def verify(self):
        self._start_session(logic.circtest_verify_command, self.VERIFY_TRACES)

    def _start_session(self, command, traces):
        def go():
            self.traces = traces
            argv = command(self.programs, self.setup())
            self.run_button.setEnabled(False)
            self.verify_button.setEnabled(False)
            self.log.clear()
            self.session_dir = None
            self.session_running = True
            self.source = None
            self.plot.set_polar(None)
            self.launch(argv, self._session_done, self._session_line, self._session_failed)
            self.tabs.setCurrentIndex(1)
            self.say("running: " + " ".join(os.path.basename(a) for a in argv[:2]))
        self._guarded(go)

    def _session_line(self, line):
        self.log.appendPlainText(line)
        folder = logic.session_folder(line)
        if folder:
            self.session_dir = folder
            self.live_timer.start()

    def _session_done(self, stdout):
        """The test ended with its results (verify's verdict OUT OF TOLERANCE or NOT DECIDED,
        exit 9, too): its verdict, when it has one, on the status line."""
        self.session_running = False  # the timer reads on until the trace is read whole
        self.live_timer.start()
        self._idle()
        verdict = logic.verdict_line(stdout)
        self.say("the test ended, %s: results below" % verdict if verdict
                 else "the test ended: results below")
        self.load_session()

    def _session_failed(self):
        """A test that ended otherwise (refused, incomplete): the plot reads what was
        recorded; nothing is analysed, so no results are shown."""
        self.session_running = False
        if self.session_dir:
            self.live_timer.start()

    # ---- live plot ---------------------------------------------------------------------------

    def poll_live(self):
        try:
            self._poll_live()
        except Exception as exc:  # noqa: BLE001 (a trace the plot cannot read: said, not raised)
            self.live_timer.stop()
            self.say(records.error_line(exc))

    def _poll_live(self):
        if not self.session_dir:
            return
        if self.source is None or self.source.rows == 0:
            for name in self.traces:
                path = os.path.join(self.session_dir, name)
                if os.path.exists(path):
                    if self.source is None or self.source.tail.path != path:
                        self.source = live.LiveSource(path)
                    break
        if self.source is None:
            return
        if self.source.poll() == 0 and not self.session_running:
            self.live_timer.stop()
        self.plot.set_polar(self.source.polar)
        if self.source.tail.behind:
            # Catching up (the panel opened mid-run): the next read once the events waiting
            # are handled, so the screen never waits for more than one read.
            QTimer.singleShot(0, self.poll_live)
        self.run_label.setText(self.source.status)

    # ---- results and compensation ------------------------------------------------------------

    def load_session(self, session_dir=None):
        """Results, diagnosis, plan, report and history of a session folder (circtest run's
        files)."""
        self.session_dir = session_dir or self.session_dir
        if not self.session_dir:
            return
        d = self.session_dir
        try:
            tests = []
            for name, label in (("results.json", "run"), ("verify-results.json", "verify")):
                if os.path.exists(os.path.join(d, name)):
                    with open(os.path.join(d, name)) as f:
                        tests.append((label, logic.parse_json(["circana"], f.read())))
            self.show_results(tests)
            if os.path.exists(os.path.join(d, "plot.svg")):
                self.svg.load(os.path.join(d, "plot.svg"))
                self.svg.renderer().setAspectRatioMode(Qt.KeepAspectRatio)
            diagnosis = os.path.join(d, "diagnosis.json")
            if os.path.exists(diagnosis):
                with open(diagnosis) as f:
                    self.show_sources(logic.parse_json(["circana"], f.read()))
                if os.path.exists(os.path.join(d, "apply.txt")):
                    self.plan_list.clear()
                    self.plan_list.addItem("applied (apply.txt): restart LinuxCNC, then Verify")
                    self.apply_button.setEnabled(False)
                else:
                    self.request_plan()
        except Exception as exc:  # noqa: BLE001 (shown as one line, never a traceback)
            self.say(records.error_line(exc))
        self.report_page.show_session(d)
        self.history_page.show_session(d)

    def _fill(self, table, rows, keys):
        table.setRowCount(len(rows))
        for i, row in enumerate(rows):
            for j, key in enumerate(keys):
                v = row.get(key)
                text = "" if v is None else ("%.1f" % v if isinstance(v, float) else str(v))
                table.setItem(i, j, QTableWidgetItem(text))
        table.resizeColumnsToContents()

    def show_results(self, tests):
        """TESTS: (label, circana analyze --json document), the run's and the verify's."""
        rows = [dict(row, test=label) for label, document in tests
                for row in logic.result_rows(document)]
        self._fill(self.results, rows,
                   ["test", "plane", "direction", "feed_mm_per_min", "G_um", "U_G_um", "F_um",
                    "U_F_um", "H_um", "U_H_um"])

    def show_sources(self, diagnosis):
        self._fill(self.sources, logic.contribution_rows(diagnosis), ["source", "G_um",
                                                                      "percent"])

    def request_plan(self):
        def go():
            ini, diag = self.setup().ini, os.path.join(self.session_dir, "diagnosis.json")
            self.launch(logic.circcomp_plan_command(self.programs, ini, diag), self._show_plan)
            self.launch(logic.circcomp_diff_command(self.programs, ini, diag),
                        self.diff.setPlainText)
        self._guarded(go)

    def _show_plan(self, stdout):
        try:
            plan = logic.parse_json(["circcomp"], stdout)
        except logic.ProgramError as exc:
            self.say(exc.message)
            return
        self.plan_list.clear()
        self.plan_list.addItems(logic.plan_lines(plan))
        self.apply_button.setEnabled(bool(plan.get("changes")))

    def confirm_apply(self):
        return QMessageBox.question(
            self, "Apply the corrections",
            "circcomp writes the corrections into the machine's configuration (the originals "
            "kept; circcomp revert undoes it). LinuxCNC must then restart. Apply?",
            QMessageBox.Yes | QMessageBox.No, QMessageBox.No) == QMessageBox.Yes

    def apply(self):
        if not self.session_dir or not self.confirm_apply():
            self.say("nothing applied")
            return

        def go():
            diag = os.path.join(self.session_dir, "diagnosis.json")
            self.apply_button.setEnabled(False)
            self.launch(logic.circcomp_apply_command(self.programs, self.setup().ini, diag),
                        self._applied)
        self._guarded(go)

    def _applied(self, stdout):
        logic.write_apply_record(self.session_dir, stdout)
        self.say("applied: restart LinuxCNC, then press Verify")

    # ---- LinuxCNC ----------------------------------------------------------------------------

    def poll_machine(self):
        self.machine.setText(logic.machine_state(self.linuxcnc))
