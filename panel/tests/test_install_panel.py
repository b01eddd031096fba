"""`circtest install --panel` (the build's circtest) on copies of configs/sim-servo with each
screen, the result read back by LinuxCNC's own INI reader (the `linuxcnc` module's ini, which
qtvcp, AXIS and gmoccapy use) and paired as qtvcp pairs it (qt_istat: names, locations and
commands zipped by order)."""
import json
import os
import subprocess

import pytest

READ_TABS = """
import json, sys, linuxcnc
ini = linuxcnc.ini(sys.argv[1])
print(json.dumps([ini.findall("DISPLAY", k) or [] for k in
                  ("EMBED_TAB_NAME", "EMBED_TAB_COMMAND", "EMBED_TAB_LOCATION")]))
"""


@pytest.fixture
def machine(sim_servo):
    """configs/sim-servo without its own circlog wiring, as tests/e2e/session-e2e.sh makes it:
    a machine that circtest install wires."""
    lines = [line for line in open(sim_servo).read().split("\n")
             if not line.startswith("HALFILE = circlog.hal") and not line.startswith("COLUMNS")]
    open(sim_servo, "w").write("\n".join(lines))
    os.unlink(os.path.join(os.path.dirname(sim_servo), "circlog.hal"))
    return sim_servo


def tabs(ini):
    """(names, commands, locations) as LinuxCNC reads them (a clean sys.path: the real module,
    not the fake one of these tests)."""
    out = subprocess.run(["/usr/bin/python3", "-c", READ_TABS, ini], capture_output=True,
                         text=True, check=True, env={"PATH": os.environ.get("PATH", "")})
    return json.loads(out.stdout)


def with_display(ini, display, extra=""):
    text = open(ini).read().replace("DISPLAY = ./ui.py", "DISPLAY = %s%s" % (display, extra))
    open(ini, "w").write(text)
    return text


def install(programs, ini, *more):
    return subprocess.run([programs.path("circtest"), "install", "--ini", ini, "--yes"] +
                          list(more), capture_output=True, text=True)


@pytest.mark.parametrize("display, command, location", [
    ("axis", "qtvcp -x {XID} circtest", None),
    ("gmoccapy", "qtvcp -x {XID} circtest", "ntb_user_tabs"),
    ("qtvcp -d qtdragon", "qtvcp circtest", "tabWidget_utilities"),
    ("qtvcp qtdragon_hd", "qtvcp circtest", "tabWidget_utilities"),
    ("qtvcp -v qtaxis", "qtvcp circtest", "default"),
])
def test_tab_for_each_screen(programs, machine, display, command, location):
    original = with_display(machine, display)
    done = install(programs, machine, "--panel")
    assert done.returncode == 0, done.stderr
    names, commands, locations = tabs(machine)
    assert names == ["circtest"] and commands == [command]
    assert locations == ([location] if location else [])
    assert "--- a/" in done.stdout and "+EMBED_TAB_NAME = circtest" in done.stdout
    # uninstall gives the INI back byte-identical, the tab lines with the rest
    subprocess.run([programs.path("circtest"), "uninstall", "--ini", machine], check=True,
                   capture_output=True)
    assert open(machine).read() == original


def test_after_the_screens_own_tabs(programs, machine):
    with_display(machine, "gmoccapy",
                 "\nEMBED_TAB_NAME = one\nEMBED_TAB_LOCATION = box_left\n"
                 "EMBED_TAB_COMMAND = gladevcp -x {XID} one.ui\n"
                 "EMBED_TAB_NAME = two\nEMBED_TAB_LOCATION = ntb_preview\n"
                 "EMBED_TAB_COMMAND = gladevcp -x {XID} two.ui")
    assert install(programs, machine, "--panel").returncode == 0
    names, commands, locations = tabs(machine)
    assert list(zip(names, locations, commands)) == [
        ("one", "box_left", "gladevcp -x {XID} one.ui"),
        ("two", "ntb_preview", "gladevcp -x {XID} two.ui"),
        ("circtest", "ntb_user_tabs", "qtvcp -x {XID} circtest")]


@pytest.mark.parametrize("display, extra, words", [
    ("./ui.py", "", "DISPLAY = ./ui.py: this screen takes no tabs"),
    # a tab without a location: the next location line would be taken for it
    ("qtvcp qtdragon", "\nEMBED_TAB_NAME = one\nEMBED_TAB_COMMAND = qtvcp one",
     "has 1 EMBED_TAB_NAME, 1 EMBED_TAB_COMMAND and 0 EMBED_TAB_LOCATION lines"),
    ("axis", "\nEMBED_TAB_NAME = one", "has 1 EMBED_TAB_NAME, 0 EMBED_TAB_COMMAND"),
    ("axis", "\nEMBED_TAB_NAME = circtest\nEMBED_TAB_COMMAND = qtvcp -x {XID} circtest",
     "a tab named circtest is there already"),
])
def test_refusals_change_nothing(programs, machine, display, extra, words):
    original = with_display(machine, display, extra)
    done = install(programs, machine, "--panel")
    assert done.returncode == 5
    line = done.stderr.strip().splitlines()[0]
    assert line.startswith("circtest: error: %s:" % machine) and words in line
    assert open(machine).read() == original
    assert not os.path.exists(os.path.join(os.path.dirname(machine), "circtest.hal"))


def test_panel_is_installs_option(programs, machine):
    done = subprocess.run([programs.path("circtest"), "run", "--ini", machine, "--panel"],
                          capture_output=True, text=True)
    assert done.returncode == 2
    assert done.stderr.strip() == "circtest: error: --panel is install's option"


def test_without_panel_no_tab(programs, machine):
    with_display(machine, "axis")
    assert install(programs, machine).returncode == 0
    assert tabs(machine) == [[], [], []]
