"""The panel end to end on a running LinuxCNC (configs/sim-servo; panel-e2e.sh starts it, as
root in scripts/hal-sandbox, and runs this test under Xvfb): the panel's widget as the qtvcp
handler makes it, with LinuxCNC's real `linuxcnc` module, its own buttons pressed through the
whole flow (set up and preview, run with "the panel presses cycle start", apply behind its
confirmation, LinuxCNC restarted, verify), and the figures it shows (G, F, H of the run and of
the verify) equal to `circana analyze --json` of the session's traces. A screenshot of each
step into PANEL_E2E_SHOTS."""
import json
import os
import subprocess
import sys
import time

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
if "PANEL_E2E_INI" not in os.environ:
    pytest.skip("needs a running LinuxCNC: run by panel-e2e.sh (ctest -R panel.e2e)",
                allow_module_level=True)

# LinuxCNC's own module, not the stand-in conftest.py puts first on the path.
FAKES = os.path.join(HERE, "fakes")
sys.path[:] = [p for p in sys.path if os.path.abspath(p or ".") != FAKES]
sys.modules.pop("linuxcnc", None)
import linuxcnc  # noqa: E402

from PyQt5.QtCore import QPoint, Qt, QTimer  # noqa: E402
from PyQt5.QtWidgets import QApplication, QMessageBox  # noqa: E402

import circtest_logic as logic  # noqa: E402
import circtest_widgets as widgets  # noqa: E402

INI = os.environ["PANEL_E2E_INI"]
SHOTS = os.environ["PANEL_E2E_SHOTS"]
# The smallest test of the session's e2e runs (session-e2e.sh's short runs): a few seconds a
# circle on sim-servo.
DIAMETER_MM, FEED = 20.0, "2000"
UM_PER_DIVISION = 50.0
RUN_S = 300  # the longest wait for a recording (a loaded machine; the runs take ~30 s)
TABS = {"setup": 0, "run": 1, "results": 2, "compensation": 3, "report": 4, "history": 5}


def seconds(t0):
    return "%.0f s" % (time.monotonic() - t0)


class Steps:
    """The panel and the screenshots of its steps."""

    def __init__(self, qtbot, panel):
        self.qtbot, self.panel, self.t0 = qtbot, panel, time.monotonic()

    def shot(self, name, tab=None, widget=None):
        if tab is not None:
            self.panel.tabs.setCurrentIndex(TABS[tab])
            QApplication.processEvents()
        path = os.path.join(SHOTS, "panel-%s.png" % name)
        assert (widget or self.panel).grab().save(path), path
        print("%s: %s" % (seconds(self.t0), path))

    def click(self, button):
        assert button.isEnabled(), button.text()
        self.qtbot.mouseClick(button, Qt.LeftButton)

    def wait_machine_ready(self):
        self.qtbot.waitUntil(
            lambda: self.panel.machine.text() == "LinuxCNC: on, homed, idle", timeout=15000)

    def wait_session_end(self, what):
        """Run or verify to its end (the buttons usable again): its results shown."""
        self.qtbot.waitUntil(lambda: self.panel.run_button.isEnabled(), timeout=RUN_S * 1000)
        assert self.panel.status.text() == "the test ended: results below", (
            what, self.panel.status.text(), self.panel.log.toPlainText()[-2000:])
        # the plot has read the whole recording
        self.qtbot.waitUntil(lambda: not self.panel.live_timer.isActive(), timeout=30000)
        print("%s: %s ended" % (seconds(self.t0), what))


def answer_dialog(qtbot, steps, button, shot):
    """Answers the next modal dialog with BUTTON, as a user's click, once it is shown (its
    screenshot SHOT first)."""
    def look():
        box = QApplication.activeModalWidget()
        if not isinstance(box, QMessageBox) or not box.isVisible():
            QTimer.singleShot(20, look)
            return
        steps.shot(shot, widget=box)
        qtbot.mouseClick(box.button(button), Qt.LeftButton)
    QTimer.singleShot(0, look)


def cli_figures(programs, trace):
    """(G, F, H) in µm per run, as `circana analyze TRACE --json` gives them (F: F_max -
    F_min; H: the H of the run's pair), in the panel's one decimal."""
    doc = json.loads(logic.run([programs.path("circana"), "analyze", trace, "--json"]))
    h_of = {i: pair["H"] for pair in doc["pairs"] for i in pair["runs"]}
    return [("%.1f" % (r["G"] * 1000), "%.1f" % (max(abs(r["F_max"]), abs(r["F_min"])) * 1000),
             "%.1f" % (h_of[i] * 1000)) for i, r in enumerate(doc["runs"])]


def panel_figures(panel, label):
    rows = [r for r in range(panel.results.rowCount()) if panel.results.item(r, 0).text() == label]
    return [tuple(panel.results.item(r, c).text() for c in (4, 6, 8)) for r in rows]


def restart_linuxcnc(qtbot):
    """The user's restart: LinuxCNC quit and started again, on and homed (panel-e2e.sh with
    PANEL_E2E_RESTART=1), the panel's events handled meanwhile."""
    log = open(os.path.join(os.environ["E2E_WORK"], "restart.log"), "w")
    restart = subprocess.Popen([os.environ["PANEL_E2E_SCRIPT"], os.environ["PANEL_E2E_BUILD"]],
                               env=dict(os.environ, PANEL_E2E_RESTART="1"), stdout=log,
                               stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
    qtbot.waitUntil(lambda: restart.poll() is not None, timeout=180000)
    log.close()
    assert restart.returncode == 0, open(log.name).read()


def test_the_whole_flow_by_the_panels_buttons(qtbot, programs):
    assert linuxcnc.__file__ and not linuxcnc.__file__.startswith(FAKES)
    # the panel as circtest_handler makes it
    panel = widgets.CircTestPanel(programs, linuxcnc, "")
    qtbot.addWidget(panel)
    panel.resize(960, 720)
    with qtbot.waitExposed(panel):
        panel.show()
    steps = Steps(qtbot, panel)
    steps.wait_machine_ready()

    # Set up: the INI, D and F, the panel presses cycle start (a simulator); the preview.
    panel.ini_edit.clear()
    qtbot.keyClicks(panel.ini_edit, INI)
    panel.diameter.setValue(DIAMETER_MM)
    panel.feeds.clear()
    qtbot.keyClicks(panel.feeds, FEED)
    qtbot.mouseClick(panel.start_box, Qt.LeftButton, pos=QPoint(8, panel.start_box.height() // 2))
    assert panel.start_box.isChecked()
    steps.click(panel.preview_button)
    qtbot.waitUntil(lambda: bool(panel.preview.points), timeout=30000)
    assert panel.status.text().startswith("circgen: the program is within"), panel.status.text()
    assert max(x for x, _ in panel.preview.points) - min(x for x, _ in panel.preview.points) == \
        pytest.approx(DIAMETER_MM)
    steps.shot("1-setup", "setup")

    # Run: circtest run --start (nothing applied), the recording drawn (at a scale that holds
    # sim-servo's lag at this feed: its deviations reach -120 µm), the results.
    panel.scale.setValue(UM_PER_DIVISION)
    steps.click(panel.run_button)
    steps.wait_session_end("run")
    session = panel.session_dir
    assert os.path.samefile(os.path.dirname(session),
                            os.path.join(os.path.dirname(INI), "circtest-sessions"))
    assert not os.path.exists(os.path.join(session, "apply.txt"))  # run applied nothing
    assert panel.plot.polar is not None and len(panel.plot.polar.runs) == 2
    steps.shot("2-run", "run")
    qtbot.waitUntil(lambda: panel.plan_list.count() > 0 and panel.diff.toPlainText() != "",
                    timeout=30000)
    before = cli_figures(programs, os.path.join(session, "trace.csv"))
    assert panel_figures(panel, "run") == before
    diagnosis = json.loads(logic.run([programs.path("circana"), "diagnose",
                                      os.path.join(session, "trace.csv"), "--json"]))
    assert [panel.sources.item(r, 0).text() for r in range(panel.sources.rowCount())] == [
        c["source"] for c in diagnosis["contributions"]]
    assert panel.svg.renderer().isValid()
    steps.shot("3-results", "results")
    steps.shot("4-compensation", "compensation")

    # Apply behind its confirmation: circcomp apply writes the corrections.
    ini_before = open(INI).read()
    answer_dialog(qtbot, steps, QMessageBox.Yes, "5-apply-confirm")
    steps.click(panel.apply_button)
    qtbot.waitUntil(lambda: panel.status.text().startswith("applied"), timeout=60000)
    assert open(INI).read() != ini_before
    assert os.path.getsize(os.path.join(session, "apply.txt")) > 0
    steps.shot("6-applied", "compensation")

    # LinuxCNC restarted (the corrections are read at start), then Verify.
    restart_linuxcnc(qtbot)
    steps.wait_machine_ready()
    steps.click(panel.verify_button)
    steps.wait_session_end("verify")
    assert panel.session_dir == session
    # The verify's own recording: its live copy (circlog-record --live), never the run's trace.
    assert panel.source.tail.path == os.path.join(session, "verify-live.csv")
    steps.shot("7-verify", "run")
    after = cli_figures(programs, os.path.join(session, "verify-trace.csv"))
    assert panel_figures(panel, "run") == before
    assert panel_figures(panel, "verify") == after
    assert panel.plan_list.item(0).text().startswith("applied (apply.txt)")
    # the corrections applied through the panel act after the restart (H, G: lower)
    assert float(after[0][2]) < float(before[0][2])
    assert max(float(g) for g, _, _ in after) < max(float(g) for g, _, _ in before)
    steps.shot("8-before-after", "results")
    print("G, F, H (um) per run: before %s, after %s" % (before, after))
    check_report(qtbot, panel, session, before, after)
    steps.shot("9-report", "report")
    check_history(qtbot, panel, before, after)
    steps.shot("10-history", "history")


def check_report(qtbot, panel, session, before, after):
    """The report verify wrote: its path, page 1's H and G before and after (the CLI's) with U
    (verify-results.json's), and circana's before/after plot with G of each run."""
    page = panel.report_page
    assert page.report_path == os.path.join(session, "report.html")
    assert page.open_button.isEnabled()
    table = page.verdict
    header = [table.horizontalHeaderItem(c).text() for c in range(table.columnCount())]
    # before, U (k = 2) of before, this test, U (k = 2) of this test, ...: before, after, U after
    cols = (header.index("before"), header.index("this test"), header.index("this test") + 1)
    assert header[cols[2]] == "U (k = 2)", header
    rows = {table.item(r, 1).text(): [table.item(r, c).text() for c in cols]
            for r in range(table.rowCount())}
    assert rows["H"][:2] == [before[0][2] + " µm", after[0][2] + " µm"], rows
    assert rows["G"][:2] == ["%.1f µm" % max(float(g) for g, _, _ in figures)
                             for figures in (before, after)], rows
    verify = json.load(open(os.path.join(session, "verify-results.json")))
    assert rows["H"][2] == "%.1f µm" % (verify["U_H"] * 1000), rows
    qtbot.waitUntil(lambda: "XY" in page.plot_paths or bool(page.problem.text()),
                    timeout=60000)
    assert page.problem.text() == ""
    assert page.g_label.text() == "XY: G before %s µm, after %s µm" % (
        ", ".join(g for g, _, _ in before), ", ".join(g for g, _, _ in after))


def check_history(qtbot, panel, before, after):
    """The machine's history: circtest run stored the test before the corrections, circtest
    verify the one after; the latest two rows are those, in that order."""
    page = panel.history_page
    qtbot.waitUntil(lambda: page.table.rowCount() > 1 or bool(page.problem.text()),
                    timeout=60000)
    assert page.problem.text() == ""
    latest = page.table.rowCount() - 1
    for row, figures in ((latest - 1, before), (latest, after)):
        assert page.table.item(row, 3).text().startswith(figures[0][2] + " ± ")
        assert page.table.item(row, 4).text().startswith(
            "%.1f ± " % max(float(g) for g, _, _ in figures))
