"""The panel offscreen (QT_QPA_PLATFORM=offscreen, pytest-qt): the flow with the real
circana/circcomp and a stand-in for `circtest run` (LinuxCNC is not running here), LinuxCNC's
status through a fake `linuxcnc` module, errors as the programs' one line."""
import hashlib
import math
import os
import stat

import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

import circtest_logic as logic  # noqa: E402
import circtest_widgets as widgets  # noqa: E402
import linuxcnc as fake_linuxcnc  # noqa: E402  (tests/fakes)
from conftest import simulate  # noqa: E402


def script(path, text):
    path.write_text("#!/bin/sh\n" + text)
    path.chmod(path.stat().st_mode | stat.S_IXUSR)
    return str(path)


def panel_with(qtbot, programs, circtest_script, ini="machine.ini"):
    paths = dict(programs.paths, circtest=circtest_script)
    panel = widgets.CircTestPanel(logic.Programs(paths), fake_linuxcnc, ini)
    qtbot.addWidget(panel)
    return panel


def session_folder(tmp_path, programs, ini):
    """What `circtest run` leaves in its session folder, made by the real circana."""
    d = tmp_path / "session"
    d.mkdir()
    trace = simulate(d / "trace.csv", "--d", "100", "--f", "1000", "--backlash-x", "0.01")
    digest = hashlib.sha256(open(ini, "rb").read()).hexdigest()
    text = open(trace).read()
    open(trace, "w").write("# ini_sha256: %s\n%s" % (digest, text))
    circana = programs.path("circana")
    (d / "results.json").write_text(logic.run([circana, "analyze", trace, "--json"]))
    logic.run([circana, "analyze", trace, "--svg", str(d / "plot.svg")])
    (d / "diagnosis.json").write_text(logic.run([circana, "diagnose", trace, "--json"]))
    (d / "report.html").write_text("<html></html>")
    return d


def test_machine_line_from_the_status_channel(qtbot, programs, tmp_path):
    fake_linuxcnc.MODE = "gone"
    panel = panel_with(qtbot, programs, script(tmp_path / "c", "exit 0\n"))
    assert panel.machine.text().startswith("no LinuxCNC runs (emcStatusBuffer invalid")
    fake_linuxcnc.MODE = "ready"
    panel.poll_machine()
    assert panel.machine.text() == "LinuxCNC: on, homed, idle"
    fake_linuxcnc.MODE = "estop"
    panel.poll_machine()
    assert panel.machine.text() == "LinuxCNC: E-stop, homed, idle"
    panel.linuxcnc = None
    panel.poll_machine()
    assert "not installed" in panel.machine.text()


def test_a_refusal_is_its_one_line(qtbot, programs, tmp_path):
    refusing = script(tmp_path / "circtest",
                      "echo 'circtest: checking LinuxCNC'\n"
                      "echo 'Traceback (most recent call last):' >&2\n"
                      "echo 'circtest: error: a joint is not homed: home the machine' >&2\n"
                      "exit 7\n")
    panel = panel_with(qtbot, programs, refusing)
    qtbot.mouseClick(panel.run_button, widgets.Qt.LeftButton)
    assert not panel.run_button.isEnabled()  # the GUI thread goes on; the program runs
    qtbot.waitUntil(lambda: panel.run_button.isEnabled(), timeout=10000)
    assert panel.status.text() == "circtest: error: a joint is not homed: home the machine"
    assert panel.log.toPlainText() == "circtest: checking LinuxCNC"


def test_an_incomplete_test_keeps_its_plot(qtbot, programs, tmp_path):
    # circtest run's exit 5: the session folder and the recorded trace stay, nothing analysed
    d = tmp_path / "session"
    d.mkdir()
    simulate(d / "trace.csv", "--d", "100", "--f", "1000")
    incomplete = script(tmp_path / "circtest",
                        "echo 'circtest: session folder %s'\n"
                        "echo 'circtest: error: the test is incomplete (E-stop)' >&2\nexit 5\n"
                        % d)
    panel = panel_with(qtbot, programs, incomplete)
    qtbot.mouseClick(panel.run_button, widgets.Qt.LeftButton)
    qtbot.waitUntil(lambda: panel.run_button.isEnabled(), timeout=10000)
    assert panel.status.text() == "circtest: error: the test is incomplete (E-stop)"
    qtbot.waitUntil(lambda: not panel.live_timer.isActive(), timeout=15000)
    assert len(panel.plot.polar.runs) == 2
    assert panel.results.rowCount() == 0


def test_a_program_that_is_not_there(qtbot, programs, tmp_path):
    panel = panel_with(qtbot, programs, str(tmp_path / "absent"))
    qtbot.mouseClick(panel.run_button, widgets.Qt.LeftButton)
    qtbot.waitUntil(lambda: panel.run_button.isEnabled(), timeout=10000)
    assert panel.status.text() == "%s: could not be started" % (tmp_path / "absent")


def test_bad_setup_is_refused_before_anything_runs(qtbot, programs, tmp_path):
    marker = tmp_path / "ran"
    panel = panel_with(qtbot, programs, script(tmp_path / "c", "touch %s\n" % marker))
    panel.feeds.setText("fast")
    qtbot.mouseClick(panel.run_button, widgets.Qt.LeftButton)
    assert panel.status.text().startswith("circtest panel: error: feeds: expected")
    panel.feeds.setText("1000")
    panel.plane_boxes["XY"].setChecked(False)
    qtbot.mouseClick(panel.run_button, widgets.Qt.LeftButton)
    assert panel.status.text().startswith("circtest panel: error: choose one or more planes")
    assert panel.run_button.isEnabled() and not marker.exists()


def test_preview_runs_circgen(qtbot, programs, tmp_path):
    panel = panel_with(qtbot, programs, script(tmp_path / "c", "exit 0\n"), ini="")
    panel.diameter.setValue(60.0)
    qtbot.mouseClick(panel.preview_button, widgets.Qt.LeftButton)
    qtbot.waitUntil(lambda: bool(panel.preview.points), timeout=10000)
    assert max(x for x, _ in panel.preview.points) == pytest.approx(30.0)
    assert panel.status.text().startswith("circgen: the program is within")
    # Annex C: circgen's feed for D60 from a D100 F1000 reference, 1000 * sqrt(0.6) = 774.6,
    # programmed in whole mm/min; the feed field takes it over for circtest run.
    panel.preview.set_points([])
    panel.annex_c.setText("100,1000")
    qtbot.mouseClick(panel.preview_button, widgets.Qt.LeftButton)
    qtbot.waitUntil(lambda: bool(panel.preview.points), timeout=10000)
    assert panel.feeds.text() == "%g" % round(1000 * math.sqrt(0.6))
    assert panel.setup().program_options()[2:4] == ["--f", "775"]
    panel.annex_c.setText("100")
    qtbot.mouseClick(panel.preview_button, widgets.Qt.LeftButton)
    assert panel.status.text().startswith("circtest panel: error: Annex C reference: expected")
    panel.annex_c.setText("")
    panel.diameter.setValue(1.0)
    panel.feeds.setText("1e9")
    qtbot.mouseClick(panel.preview_button, widgets.Qt.LeftButton)
    qtbot.waitUntil(lambda: panel.status.text().startswith("circgen: error:"), timeout=10000)


def test_the_flow_shows_the_programs_numbers(qtbot, programs, tmp_path, sim_servo,
                                             monkeypatch):
    d = session_folder(tmp_path, programs, sim_servo)
    # The stand-in announces the folder as circtest run and verify do (verify first as the
    # session it verifies, both at their end); as verify, its recording appears a moment later.
    run = script(tmp_path / "circtest",
                 "if [ \"$1\" = verify ]; then\n"
                 "  echo 'circtest: verifying session {0}: its program again'\n"
                 "else echo 'circtest: session folder {0}'; fi\nsleep 0.5\n"
                 "if [ -f {0}/pending.csv ]; then mv {0}/pending.csv {0}/verify-trace.csv; fi\n"
                 "echo 'circtest: session folder {0}'\n"
                 .format(d))
    panel = panel_with(qtbot, programs, run, ini=sim_servo)
    qtbot.mouseClick(panel.run_button, widgets.Qt.LeftButton)
    qtbot.waitUntil(lambda: panel.plan_list.count() > 0, timeout=15000)
    qtbot.waitUntil(lambda: panel.diff.toPlainText() != "", timeout=15000)

    # Results: circana's G, F and H in µm, one decimal.
    results = logic.parse_json(["circana"], (d / "results.json").read_text())
    for i, r in enumerate(results["runs"]):
        assert panel.results.item(i, 0).text() == "run"
        assert panel.results.item(i, 4).text() == "%.1f" % (r["G"] * 1000.0)
        assert panel.results.item(i, 5).text() == "%.1f" % (r["U_G"] * 1000.0)
        assert panel.results.item(i, 7).text() == "%.1f" % (r["U_F"] * 1000.0)
        assert panel.results.item(i, 8).text() == "%.1f" % (results["pairs"][0]["H"] * 1000)
        assert panel.results.item(i, 9).text() == "%.1f" % (results["U_H"] * 1000)
    assert panel.sources.item(0, 0).text() == "backlash X"
    assert panel.plan_list.item(0).text() == "[JOINT_0] X backlash 0 → 10.0 µm"
    assert "+BACKLASH = 0.01" in panel.diff.toPlainText()
    # The live plot draws the recorded runs (read in bounded steps, 10 per second).
    qtbot.waitUntil(lambda: not panel.live_timer.isActive(), timeout=15000)
    assert [r.segment for r in panel.plot.polar.runs] == [1, 2]
    assert panel.report_button.isEnabled()
    assert panel.svg.renderer().isValid()  # circana's plot.svg shown

    # Apply: declined, nothing; confirmed, circcomp apply and the session's apply.txt.
    before = open(sim_servo).read()
    monkeypatch.setattr(panel, "confirm_apply", lambda: False)
    qtbot.mouseClick(panel.apply_button, widgets.Qt.LeftButton)
    assert panel.status.text() == "nothing applied" and open(sim_servo).read() == before
    monkeypatch.setattr(panel, "confirm_apply", lambda: True)
    qtbot.mouseClick(panel.apply_button, widgets.Qt.LeftButton)
    qtbot.waitUntil(lambda: panel.status.text().startswith("applied"), timeout=15000)
    assert "BACKLASH = 0.01" in open(sim_servo).read()
    assert (d / "apply.txt").read_text().strip() != ""

    # Verify: the same session folder with verify-results.json (circana's JSON of the run
    # after the corrections) beside the run's; the plan is not offered again.
    trace = simulate(d / "pending.csv", "--d", "100", "--f", "1000", "--backlash-x", "0.002")
    (d / "verify-results.json").write_text(
        logic.run([programs.path("circana"), "analyze", trace, "--json"]))
    qtbot.mouseClick(panel.verify_button, widgets.Qt.LeftButton)
    qtbot.waitUntil(lambda: panel.results.rowCount() == 4, timeout=15000)
    after = logic.parse_json(["circana"], (d / "verify-results.json").read_text())
    assert [panel.results.item(i, 0).text() for i in range(4)] == ["run", "run", "verify",
                                                                   "verify"]
    assert panel.results.item(2, 8).text() == "%.1f" % (after["pairs"][0]["H"] * 1000)
    assert panel.results.item(2, 8).text() == "2.0"  # the 2 µm backlash left
    assert not panel.apply_button.isEnabled()
    assert panel.plan_list.item(0).text().startswith("applied (apply.txt)")
    # the plot shows the verify's recording, not the run's trace.csv beside it
    qtbot.waitUntil(lambda: not panel.live_timer.isActive(), timeout=15000)
    assert panel.source.tail.path == str(d / "verify-trace.csv")

    # Applying again: circcomp's refusal shows as its line.
    monkeypatch.setattr(panel, "confirm_apply", lambda: True)
    panel.apply_button.setEnabled(True)
    qtbot.mouseClick(panel.apply_button, widgets.Qt.LeftButton)
    qtbot.waitUntil(lambda: panel.status.text().startswith("circcomp: "), timeout=15000)


def test_verify_out_of_tolerance_shows_its_results(qtbot, programs, tmp_path, sim_servo):
    # circtest verify against the session's limits, not within them: exit 9 after the session
    # folder is complete (docs/session.md). The panel shows the verify's results and its
    # verdict, not an error.
    d = session_folder(tmp_path, programs, sim_servo)
    (d / "apply.txt").write_text("applied\n")
    trace = simulate(d / "verify-trace.csv", "--d", "100", "--f", "1000", "--backlash-x", "0.002")
    (d / "verify-results.json").write_text(
        logic.run([programs.path("circana"), "analyze", trace, "--json"]))
    verdict = ("verdict against H=0.001 (ISO 14253-1, U k = 2): OUT OF TOLERANCE: H 2.0 - U 0.1 "
               "> 1.0 um")
    verify = script(tmp_path / "circtest",
                    "echo 'circtest: verifying session {0}: its program again'\n"
                    "echo 'circtest: {1}' && echo 'circtest: session folder {0}'\n"
                    "exit 9\n".format(d, verdict))
    panel = panel_with(qtbot, programs, verify, ini=sim_servo)
    qtbot.mouseClick(panel.verify_button, widgets.Qt.LeftButton)
    qtbot.waitUntil(lambda: panel.results.rowCount() == 4, timeout=15000)
    assert [panel.results.item(i, 0).text() for i in range(4)] == ["run", "run", "verify",
                                                                   "verify"]
    assert panel.results.item(2, 8).text() == "2.0"  # the verify's H, the 2 µm backlash left
    assert panel.status.text() == "the test ended, %s: results below" % verdict
    assert panel.verify_button.isEnabled() and panel.run_button.isEnabled()
    # Any other exit of verify is its error line, nothing loaded.
    (d / "verify-results.json").unlink()
    panel.results.setRowCount(0)
    failing = script(tmp_path / "circtest",
                     "echo 'circtest: error: m.ini: LinuxCNC is not running' >&2\nexit 7\n")
    panel = panel_with(qtbot, programs, failing, ini=sim_servo)
    qtbot.mouseClick(panel.verify_button, widgets.Qt.LeftButton)
    qtbot.waitUntil(lambda: panel.status.text().startswith("circtest: error:"), timeout=15000)
    assert panel.results.rowCount() == 0


def test_plot_paints_offscreen(qtbot, programs, tmp_path):
    trace = simulate(tmp_path / "t.csv", "--d", "100", "--f", "1000", "--backlash-x", "0.01")
    plot = widgets.PolarPlot()
    qtbot.addWidget(plot)
    plot.resize(400, 400)
    source = __import__("circtest_live").LiveSource(trace)
    source.tail.max_bytes_per_poll = 1 << 30
    source.poll()
    plot.set_polar(source.polar)
    image = plot.grab().toImage()
    colours = {image.pixelColor(x, y).name() for x in range(0, 400, 2) for y in range(0, 400, 2)}
    assert {"#1f77b4", "#d62728"} & colours  # both runs' colours appear (antialiased edges)


def test_handler_puts_the_panel_in_the_ui(qtbot, programs, monkeypatch):
    from PyQt5.QtWidgets import QVBoxLayout, QWidget
    import circtest_handler

    holder = QWidget()
    qtbot.addWidget(holder)

    class Widgets:
        panel_layout = QVBoxLayout(holder)

    monkeypatch.setenv("INI_FILE_NAME", "/cfg/machine.ini")
    handler = circtest_handler.get_handlers(None, Widgets, None)[0]
    handler.initialized__()
    assert Widgets.panel_layout.itemAt(0).widget() is handler.panel
    assert handler.panel.ini_edit.text() == "/cfg/machine.ini"
