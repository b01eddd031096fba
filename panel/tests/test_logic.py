"""circtest_logic against the real programs of the build."""
import hashlib
import json
import math
import os

import pytest

import circtest_logic as logic
from conftest import simulate


def test_results_are_circanas(programs, tmp_path):
    # 10 µm backlash on X injected: H is the backlash (circana's own tests hold it to that).
    trace = simulate(tmp_path / "t.csv", "--d", "100", "--f", "1000", "--backlash-x", "0.01")
    argv = logic.circana_analyze_command(programs, trace)
    document = logic.run_json(argv)
    rows = logic.result_rows(document)
    assert [r["direction"] for r in rows] == ["CCW", "CW"]
    assert rows[0]["H_um"] == pytest.approx(10.0, abs=0.3)
    for row, run in zip(rows, document["runs"]):
        assert row["G_um"] == run["G"] * 1000.0
        assert row["F_um"] == max(abs(run["F_max"]), abs(run["F_min"])) * 1000.0
        assert row["H_um"] == document["pairs"][0]["H"] * 1000.0
        # each with its U (k = 2) as circana states it
        assert row["U_G_um"] == run["U_G"] * 1000.0 and row["U_G_um"] > 0
        assert row["U_F_um"] == run["U_F"] * 1000.0 and row["U_F_um"] > 0
        assert row["U_H_um"] == document["U_H"] * 1000.0 and row["U_H_um"] > 0


def test_diagnosis_shares(programs, tmp_path):
    trace = simulate(tmp_path / "t.csv", "--d", "100", "--f", "1000", "--backlash-x", "0.01",
                     "--squareness", "100e-6")
    diagnosis = logic.run_json([programs.path("circana"), "diagnose", trace, "--json"])
    rows = logic.contribution_rows(diagnosis)
    assert rows[0]["source"] == "backlash X"
    assert rows[0]["G_um"] == pytest.approx(10.0, abs=0.3)
    assert any(r["source"] == "squareness" for r in rows)


def test_missing_trace_is_circanas_one_line(programs, tmp_path):
    missing = str(tmp_path / "nope.csv")
    with pytest.raises(logic.ProgramError) as caught:
        logic.run(logic.circana_analyze_command(programs, missing))
    assert caught.value.message == "circana: error: %s: cannot open: No such file or directory" \
        % missing
    assert caught.value.exit_code == 3


def test_bad_trace_names_its_line(programs, tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("t,x\n1,2\n")
    with pytest.raises(logic.ProgramError) as caught:
        logic.run(logic.circana_analyze_command(programs, str(bad)))
    assert caught.value.message.startswith("circana: error: %s:1: missing column 'y'" % bad)
    assert caught.value.exit_code == 4


def test_circgen_refusal(programs, tmp_path):
    setup = logic.Setup(diameter_mm=100.0, feeds_mm_per_min=(1000.0,))
    setup.diameter_mm = 1e9  # the form is right; circgen's plausible range refuses it
    with pytest.raises(logic.ProgramError) as caught:
        logic.run(logic.circgen_command(programs, setup, str(tmp_path / "p.ngc")))
    assert caught.value.message.startswith("circgen: error: --d")
    assert caught.value.exit_code == 2
    assert not os.path.exists(tmp_path / "p.ngc")


def test_preview_is_circgens_circle(programs, tmp_path):
    out = str(tmp_path / "p.ngc")
    setup = logic.Setup(planes=("XY",), diameter_mm=80.0, feeds_mm_per_min=(500.0,))
    argv = logic.circgen_command(programs, setup, out) + ["--centre", "10,20,0"]
    logic.run(argv)
    header = logic.program_header(out)
    points = logic.preview_path(header)
    for x, y in points:
        assert math.hypot(x - 10.0, y - 20.0) == pytest.approx(40.0, abs=1e-9)
    # circgen's default: a 360° data arc with 10° leads on each side, from 0°.
    first = math.degrees(math.atan2(points[0][1] - 20.0, points[0][0] - 10.0))
    assert first == pytest.approx(-10.0, abs=1e-6)
    assert float(header["arc_total_deg"]) == 380.0


def test_plan_lines_and_apply(programs, tmp_path, sim_servo):
    # Backlash: circcomp corrects it in a COMP_FILE (squareness would need circtest_kins.so
    # installed where LinuxCNC's loadrt looks).
    trace = simulate(tmp_path / "t.csv", "--d", "100", "--f", "1000", "--backlash-x", "0.01")
    diagnosis = tmp_path / "diagnosis.json"
    diagnosis.write_text(logic.run([programs.path("circana"), "diagnose", trace, "--json"]))
    # Without the INI's SHA-256 in the trace circcomp refuses: its line, not a traceback.
    with pytest.raises(logic.ProgramError) as caught:
        logic.run(logic.circcomp_apply_command(programs, sim_servo, str(diagnosis)))
    assert caught.value.exit_code == 10
    assert caught.value.message.startswith("circcomp: error: %s: has no ini_sha256" % diagnosis)
    add_provenance(trace, sim_servo)
    diagnosis.write_text(logic.run([programs.path("circana"), "diagnose", trace, "--json"]))
    plan = logic.run_json(logic.circcomp_plan_command(programs, sim_servo, str(diagnosis)))
    lines = logic.plan_lines(plan)
    assert lines[0] == "[JOINT_0] X backlash 0 → 10.0 µm"
    before = open(sim_servo).read()
    out = logic.run(logic.circcomp_apply_command(programs, sim_servo, str(diagnosis)))
    assert open(sim_servo).read() != before
    assert "BACKLASH = 0.01" in open(sim_servo).read()
    record = logic.write_apply_record(str(tmp_path), out)
    assert open(record).read() == out
    assert [n for n in os.listdir(tmp_path) if n.startswith(".apply.")] == []


def add_provenance(trace, ini):
    """The INI's SHA-256 in the trace's metadata, as circlog-record --ini writes it."""
    digest = hashlib.sha256(open(ini, "rb").read()).hexdigest()
    text = open(trace).read()
    open(trace, "w").write("# ini: %s\n# ini_sha256: %s\n%s" % (ini, digest, text))


def test_command_lines(programs):
    setup = logic.Setup("m.ini", ("XY", "YZ"), 150.0, (500.0, 1000.0), start=True)
    argv = logic.circtest_run_command(programs, setup)
    assert argv[1:] == ["run", "--ini", "m.ini", "--d", "150", "--feeds", "500,1000",
                        "--plane", "XY,YZ", "--start"]
    assert "--yes" not in argv  # the panel applies only after its own confirmation
    assert logic.circtest_verify_command(programs, setup)[1:] == ["verify", "--ini", "m.ini",
                                                                  "--start"]


@pytest.mark.parametrize("setup, words", [
    (logic.Setup(planes=()), "planes"),
    (logic.Setup(planes=("XZ",)), "planes"),
    (logic.Setup(diameter_mm=float("nan")), "diameter"),
    (logic.Setup(feeds_mm_per_min=(1000.0, 0.0)), "feed"),
])
def test_setup_refusals(setup, words):
    with pytest.raises(logic.ProgramError) as caught:
        setup.check()
    assert words in caught.value.message
    assert caught.value.message.startswith("circtest panel: error: ")


def test_feeds_text():
    assert logic.parse_feeds("500, 1000") == [500.0, 1000.0]
    with pytest.raises(logic.ProgramError):
        logic.parse_feeds("fast")


def test_one_line_error():
    noise = "note: something\ncircana: error: t.csv:3: bad\nmore\n"
    assert logic.one_line_error("circana", 4, noise) == "circana: error: t.csv:3: bad"
    assert logic.one_line_error("x", 1, "last words\n") == "last words"
    assert logic.one_line_error("x", -9, "") == "x: stopped by signal 9"
    assert logic.one_line_error("x", 3, "") == "x: failed with exit code 3 and no message"


def test_verify_out_of_tolerance_is_a_result():
    # circtest verify's exit 9 (its verdict against the limits: README's exit codes) returns
    # its output as exit 0 does; another program's 9, run's, or verify's other exits fail.
    verdict = ("circtest: verdict against G=0.0125 (ISO 14253-1, U k = 2): NOT DECIDED: G 12.0 "
               "+ U 1.0 > 12.5 um: within the uncertainty")
    out = "circtest: verifying session /a/s: its program again\n%s\n" % verdict
    assert logic.finish(["/bin/circtest", "verify", "--ini", "m.ini"], 9, out, "") == out
    assert logic.verdict_line(out) == verdict[len("circtest: "):]
    assert logic.verdict_line("circtest: no acceptance limits set (...): no verdict\n") is None
    for argv, code in ((["/bin/circtest", "verify"], 7), (["/bin/circtest", "run"], 9),
                       (["/bin/circana", "history"], 9)):
        with pytest.raises(logic.ProgramError) as caught:
            logic.finish(argv, code, out, "x: error: refused\n")
        assert (caught.value.exit_code, caught.value.message) == (code, "x: error: refused")


def test_missing_program():
    with pytest.raises(logic.ProgramError) as caught:
        logic.Programs({}).path("circtest")
    assert caught.value.exit_code == 127
    assert "CIRCTEST_BINDIR" in caught.value.message


def test_find_programs(tmp_path):
    tool = tmp_path / "circana"
    tool.write_text("#!/bin/sh\n")
    tool.chmod(0o755)
    assert logic.find_programs({"CIRCTEST_BINDIR": str(tmp_path)}) == {"circana": str(tool)}


def test_session_folder_line():
    assert logic.session_folder("circtest: session folder /a/b\n") == "/a/b"
    assert logic.session_folder("circtest: program /a/p.ngc") is None
    # circtest verify's line (session/src/verify.cpp)
    assert logic.session_folder(
        "circtest: verifying session /a/m-20260101T000000Z: its program again") == \
        "/a/m-20260101T000000Z"


def test_machine_state():
    import linuxcnc as fake
    assert "not installed" in logic.machine_state(None)
    fake.MODE = "gone"
    assert logic.machine_state(fake).startswith("no LinuxCNC runs (emcStatusBuffer")
    fake.MODE = "no-mmap"
    assert logic.machine_state(fake).startswith("no LinuxCNC runs (<method 'poll'")
    fake.MODE = "ready"
    assert logic.machine_state(fake) == "LinuxCNC: on, homed, idle"
    fake.MODE = "estop"
    assert logic.machine_state(fake) == "LinuxCNC: E-stop, homed, idle"


def test_test_set_rows():
    ev = {"plane": "YZ", "pairs": [{"runs": [0, 1], "H": 0.002}],
          "runs": [{"direction": "CCW", "G": 0.003, "F_max": 0.001, "F_min": -0.001},
                   {"direction": "CW", "G": 0.004, "F_max": None, "F_min": None}]}
    rows = logic.result_rows({"test_set": [], "planes": [ev, ev]})
    assert len(rows) == 4 and rows[2]["plane"] == "YZ"
    assert rows[1]["F_um"] is None and rows[1]["H_um"] == pytest.approx(2.0)
    # a document without U: said, not left blank; no value, no U
    assert rows[0]["U_G_um"] == "not known" and rows[0]["U_H_um"] == "not known"
    assert rows[1]["U_F_um"] is None
    json.dumps(rows)


def test_annex_c_feed_is_circgens(programs, tmp_path):
    out = str(tmp_path / "p.ngc")
    setup = logic.Setup(diameter_mm=150.0, annex_c=(100.0, 1000.0))
    argv = logic.circgen_command(programs, setup, out)
    assert "--f" not in argv and argv[argv.index("--ref-d") + 1] == "100"
    logic.run(argv)
    # V1 = V2 sqrt(D1 / D2) (ISO 230-4 Annex C), programmed in whole mm/min
    assert logic.program_feeds(logic.program_header(out)) == [round(1000 * math.sqrt(1.5))]
