"""The panel's Report and History steps (Qt): the session's hand-over report (its path, its
first page's verdict with H, G, F before and after and their U, k = 2, opened in the desktop's
viewer), circana's before/after plot, and the machine's history trend. They show what
circtest_records reads from the programs; a program's failure is its one line, on the step."""
import html
import math
import os

from PyQt5.QtCore import QPointF, QRectF, Qt, QUrl
from PyQt5.QtGui import QColor, QDesktopServices, QPainter, QPen
from PyQt5.QtSvg import QSvgWidget
from PyQt5.QtWidgets import (QHBoxLayout, QLabel, QPushButton, QTableWidget, QTableWidgetItem,
                             QVBoxLayout, QWidget)

import circtest_logic as logic
import circtest_records as records

VERDICT_COLOURS = {"PASS": "#2ca02c", "FAIL": "#d62728", "OPEN": "#ff7f0e", "NONE": "#606060"}
PLANE_COLOURS = {"XY": "#1f77b4", "YZ": "#d62728", "ZX": "#2ca02c"}


class ProblemLabel(QLabel):
    """A step's errors, each the one line a program (or the panel) said, under each other."""

    def __init__(self):
        super().__init__("")
        self.setWordWrap(True)
        self.setStyleSheet("color: #d62728")
        self.setTextInteractionFlags(Qt.TextSelectableByMouse)

    def add(self, line):
        self.setText(line if not self.text() else self.text() + "\n" + line)


def fill_table(table, header, rows):
    table.setColumnCount(len(header))
    table.setHorizontalHeaderLabels(header)
    table.setRowCount(len(rows))
    for i, row in enumerate(rows):
        for j, text in enumerate(row):
            table.setItem(i, j, QTableWidgetItem(text))
    table.resizeColumnsToContents()
    table.verticalHeader().setVisible(False)


class ReportPage(QWidget):
    """The report of the session: where it is, Open, page 1's verdict table, and after Verify
    the before/after plot (circana analyze --compare) with G before and after."""

    def __init__(self, panel):
        super().__init__()
        self.panel = panel
        self.report_path = None
        self.plot_paths = {}
        self.generation = 0
        self.path_label = QLabel("No report yet: it is written at the end of a run and of Verify")
        self.path_label.setWordWrap(True)
        self.path_label.setTextInteractionFlags(Qt.TextSelectableByMouse)
        self.open_button = QPushButton("Open the report")
        self.open_button.setEnabled(False)
        self.open_button.clicked.connect(self.open_report)
        self.chromium = records.chromium_path()
        self.pdf_button = QPushButton("Save as PDF")
        self.pdf_button.setEnabled(False)
        self.pdf_button.setToolTip("report.pdf beside the report, printed by Chromium" if
                                   self.chromium else "needs Debian's chromium: else open the "
                                   "report and print it from the viewer")
        self.pdf_button.clicked.connect(self.save_pdf)
        self.banner = QLabel("")
        self.banner.setWordWrap(True)
        self.verdict = QTableWidget(0, 0)
        self.g_label = QLabel("")
        self.g_label.setWordWrap(True)
        self.problem = ProblemLabel()
        self.plots = QHBoxLayout()
        top = QHBoxLayout()
        top.addWidget(self.path_label, 1)
        top.addWidget(self.open_button)
        top.addWidget(self.pdf_button)
        left = QVBoxLayout()
        left.addWidget(self.verdict)
        left.addWidget(self.problem)
        left.addWidget(QLabel("Before and after: circana analyze --compare, one scale"))
        left.addWidget(self.g_label)
        left.addStretch(1)
        middle = QHBoxLayout()
        middle.addLayout(left)
        middle.addLayout(self.plots, 1)
        box = QVBoxLayout(self)
        box.addLayout(top)
        box.addWidget(self.banner)
        box.addLayout(middle, 1)

    def clear(self):
        self.report_path = None
        self.open_button.setEnabled(False)
        self.pdf_button.setEnabled(False)
        self.banner.setText("")
        self.verdict.setRowCount(0)
        self.g_label.setText("")
        self.problem.setText("")
        self.plot_paths = {}
        self.generation += 1  # what a plot of an earlier session brings is not shown
        while self.plots.count():
            self.plots.takeAt(0).widget().deleteLater()

    def show_session(self, session_dir):
        """The report's page 1 now; the before/after plot when circana has drawn it."""
        self.clear()
        path = os.path.join(session_dir, "report.html")
        if os.path.exists(path):
            self.report_path = path
            self.path_label.setText("The report: " + path)
            self.open_button.setEnabled(True)
            self.pdf_button.setEnabled(self.chromium is not None)
            try:
                self.show_verdict(records.report_verdict(path))
            except Exception as exc:  # noqa: BLE001 (shown, never a traceback)
                self.problem.add(records.error_line(exc))
        try:
            commands = records.before_after_commands(self.panel.programs, session_dir,
                                                     self.panel.scratch.name)
            if commands:
                self.g_label.setText(records.g_before_after_text(
                    records.g_before_after(session_dir)))
        except Exception as exc:  # noqa: BLE001
            self.problem.add(records.error_line(exc))
            return
        for plane, svg, argv in commands:
            self.panel.launch(argv, lambda _out, p=plane, s=svg, g=self.generation:
                              self.show_plot(p, s, g), on_error=self.problem.add)

    def show_verdict(self, verdict):
        colour = VERDICT_COLOURS.get(verdict["verdict"], "#606060")
        self.banner.setText("<b>%s</b> — %s" % (html.escape(verdict["banner"]),
                                                html.escape(verdict["note"])))
        self.banner.setStyleSheet("color: %s" % colour)
        fill_table(self.verdict, verdict["header"], verdict["rows"])
        # as large as its cells: the plot beside it takes the rest
        table, frame = self.verdict, 2 * self.verdict.frameWidth()
        table.setMinimumWidth(frame + sum(table.columnWidth(j)
                                          for j in range(table.columnCount())))
        table.setMaximumHeight(frame + table.horizontalHeader().height() + sum(
            table.rowHeight(i) for i in range(table.rowCount())))

    def show_plot(self, plane, svg, generation):
        if generation != self.generation:
            return
        widget = QSvgWidget(svg)
        widget.renderer().setAspectRatioMode(Qt.KeepAspectRatio)  # a circle stays round
        widget.setObjectName("before-after-" + plane)
        widget.setMinimumHeight(200)
        self.plot_paths[plane] = svg
        self.plots.addWidget(widget)

    def save_pdf(self):
        """report.pdf beside the report (Chromium's print of its A4 pages), in the background."""
        if not self._report_there():
            return
        html_path = self.report_path
        pdf = os.path.splitext(html_path)[0] + ".pdf"
        partial = os.path.join(os.path.dirname(pdf), ".report-printing.pdf")
        self.pdf_button.setEnabled(False)
        self.panel.say("printing the report to PDF (Chromium)…")

        def printed(_out):
            self.pdf_button.setEnabled(True)
            self.panel.say("the report as PDF: " + records.pdf_written(partial, pdf))

        def failed(line):
            self.pdf_button.setEnabled(True)
            self.panel.say(line)

        self.panel.launch(records.pdf_command(self.chromium, html_path, partial), printed,
                          on_error=failed)

    def _report_there(self):
        if self.report_path and os.path.exists(self.report_path):
            return True
        self.panel.say("circtest panel: error: %s: the report is not there (run the test again)"
                       % self.report_path)
        return False

    def open_report(self):
        if not self._report_there():
            return
        if QDesktopServices.openUrl(QUrl.fromLocalFile(self.report_path)):
            self.panel.say("opened in the desktop's viewer: " + self.report_path)
        else:
            self.panel.say("circtest panel: error: no program on this desktop opens %s: open "
                           "it from a file manager" % self.report_path)


class TrendPlot(QWidget):
    """G and H of the machine's stored tests over time, each with its U (k = 2) as a bar from
    value - U to value + U; one colour per plane. `series` holds what is drawn, in pixels."""

    QUANTITIES = (("G", "G µm"), ("H", "H µm"))
    LEFT, RIGHT, TOP, GAP, BOTTOM = 56, 12, 10, 26, 22

    def __init__(self, parent=None):
        super().__init__(parent)
        self.tests = []
        self.setMinimumSize(300, 220)

    def set_tests(self, tests):
        self.tests = tests
        self.update()

    def _xs(self, width):
        """Each test's x: its time when every time reads, else its order (as circana's trend)."""
        seconds = [records.tested_at_seconds(t["tested_at"]) for t in self.tests]
        if any(s is None for s in seconds) or len(set(seconds)) < 2:
            seconds = list(range(len(self.tests)))
        lo, hi = min(seconds), max(seconds)
        span = (hi - lo) or 1.0
        inner = width - self.LEFT - self.RIGHT
        if len(self.tests) == 1:
            return [self.LEFT + inner / 2.0]
        return [self.LEFT + inner * (s - lo) / span for s in seconds]

    def series(self):
        """Per quantity: (panel rectangle, top value µm, [(x, y, y_low, y_high, plane)]), y_low
        and y_high the ends of the U bar (None without U)."""
        if not self.tests:
            return {}
        height = (self.height() - self.TOP - self.BOTTOM - self.GAP) / 2.0
        xs = self._xs(self.width())
        out = {}
        for k, (key, _title) in enumerate(self.QUANTITIES):
            rect = QRectF(self.LEFT, self.TOP + k * (height + self.GAP),
                          self.width() - self.LEFT - self.RIGHT, height)
            tops = [t[key + "_um"] + (t["U_" + key + "_um"] or 0.0) for t in self.tests
                    if t[key + "_um"] is not None]
            top = max(tops) * 1.1 if tops and max(tops) > 0 else 1.0

            def y(value, rect=rect, top=top):
                return rect.bottom() - rect.height() * value / top

            points = []
            for x, t in zip(xs, self.tests):
                value, u = t[key + "_um"], t["U_" + key + "_um"]
                if value is None:
                    continue
                points.append((x, y(value), None if u is None else y(max(0.0, value - u)),
                               None if u is None else y(value + u), t["plane"]))
            out[key] = (rect, top, points)
        return out

    def paintEvent(self, _event):
        painter = QPainter(self)
        painter.setRenderHint(QPainter.Antialiasing)
        painter.fillRect(self.rect(), QColor("white"))
        if not self.tests:
            painter.drawText(self.rect(), Qt.AlignCenter, "No stored test of this machine yet")
            return
        for (key, title), (rect, top, points) in zip(self.QUANTITIES, (
                self.series()[k] for k, _ in self.QUANTITIES)):
            painter.setPen(QPen(QColor("#c0c0c0")))
            painter.setBrush(Qt.NoBrush)
            painter.drawRect(rect)
            painter.setPen(QColor("black"))
            painter.drawText(QRectF(0, rect.top(), self.LEFT - 4, 16), Qt.AlignRight,
                             "%.3g" % top)
            painter.drawText(QRectF(0, rect.bottom() - 14, self.LEFT - 4, 16), Qt.AlignRight, "0")
            painter.drawText(QRectF(0, rect.center().y() - 8, self.LEFT - 4, 16), Qt.AlignRight,
                             title)
            previous = {}
            for x, y, y_low, y_high, plane in points:
                pen = QPen(QColor(PLANE_COLOURS.get(plane, "#404040")), 1.5)
                painter.setPen(pen)
                if y_low is not None:
                    painter.drawLine(QPointF(x, y_low), QPointF(x, y_high))
                    for end in (y_low, y_high):
                        painter.drawLine(QPointF(x - 4, end), QPointF(x + 4, end))
                if plane in previous:
                    painter.drawLine(previous[plane], QPointF(x, y))
                previous[plane] = QPointF(x, y)
                painter.setBrush(pen.color())
                painter.drawEllipse(QPointF(x, y), 3, 3)
        painter.setPen(QColor("black"))
        first, last = self.tests[0]["tested_at"], self.tests[-1]["tested_at"]
        painter.drawText(QRectF(self.LEFT, self.height() - 18, self.width() - self.LEFT -
                                self.RIGHT, 16), Qt.AlignLeft, first)
        if len(self.tests) > 1:
            painter.drawText(QRectF(self.LEFT, self.height() - 18, self.width() - self.LEFT -
                                    self.RIGHT, 16), Qt.AlignRight, last)


def with_u(value, u):
    if value is None:
        return "–"
    if u is None or not math.isfinite(u):
        return "%.1f (no U)" % value
    return "%.1f ± %.1f" % (value, u)


class HistoryPage(QWidget):
    """The machine's stored tests (`circana history --machine NAME --json`): the trend of G and
    H with U, and the list."""

    def __init__(self, panel):
        super().__init__()
        self.panel = panel
        self.machine = None
        self.machine_label = QLabel("The machine's history: the machine named in the INI "
                                    "([EMC] MACHINE), or the one of the last test")
        self.machine_label.setWordWrap(True)
        self.refresh_button = QPushButton("Refresh")
        self.refresh_button.clicked.connect(self.refresh)
        self.problem = ProblemLabel()
        self.trend = TrendPlot()
        self.table = QTableWidget(0, 0)
        top = QHBoxLayout()
        top.addWidget(self.machine_label, 1)
        top.addWidget(self.refresh_button)
        box = QVBoxLayout(self)
        box.addLayout(top)
        box.addWidget(self.problem)
        box.addWidget(self.trend, 3)
        box.addWidget(self.table, 2)

    def show_session(self, session_dir):
        self.problem.setText("")
        try:
            machine = records.session_machine(session_dir)
        except Exception as exc:  # noqa: BLE001
            self.problem.add(records.error_line(exc))
            return
        if not machine:
            self.problem.add("circtest panel: error: %s: the test names no machine, and the "
                                 "history is kept per machine" % session_dir)
            return
        self.show_machine(machine)

    def show_machine(self, machine):
        self.machine = machine
        self.machine_label.setText("History of machine %s (circana history; H, G, F with U, "
                                   "k = 2)" % machine)
        self.refresh()

    def refresh(self):
        """The history of the machine shown, else of the one the set-up's INI names."""
        self.problem.setText("")
        try:
            if not self.machine:
                machine = records.ini_machine(self.panel.linuxcnc,
                                              self.panel.ini_edit.text().strip())
                if not machine:
                    raise records.panel_error("no machine yet: give the machine's INI on the "
                                              "set-up step, or run a test")
                self.show_machine(machine)
                return
            argv = records.circana_history_command(self.panel.programs, self.machine)
        except Exception as exc:  # noqa: BLE001
            self.problem.add(records.error_line(exc))
            return
        self.panel.launch(argv, self._show, on_error=self._failed)

    def _failed(self, line):
        self.problem.add(line)
        self.trend.set_tests([])
        self.table.setRowCount(0)

    def _show(self, stdout):
        tests = records.history_tests(logic.parse_json(["circana"], stdout))
        self.trend.set_tests(tests)
        fill_table(self.table, ["Tested at", "Test", "Plane", "H µm", "G µm", "F µm"], [
            [t["tested_at"], str(t["id"]), t["plane"], with_u(t["H_um"], t["U_H_um"]),
             with_u(t["G_um"], t["U_G_um"]), with_u(t["F_um"], t["U_F_um"])] for t in tests])
        self.table.scrollToBottom()
