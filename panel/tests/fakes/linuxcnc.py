"""A stand-in for LinuxCNC's `linuxcnc` module: the status channel in the state MODE says
("gone": no LinuxCNC runs; "no-mmap": none either, as LinuxCNC 2.9's stat.poll() says it
without its tool table's shared memory: a SystemError; "ready": on, homed, idle; "estop")."""
MODE = "gone"

STATE_ESTOP, STATE_ESTOP_RESET, STATE_OFF, STATE_ON = 1, 2, 3, 4
INTERP_IDLE, INTERP_READING, INTERP_PAUSED, INTERP_WAITING = 1, 2, 3, 4


class error(Exception):
    pass


class stat:
    def poll(self):
        if MODE == "gone":
            raise error("emcStatusBuffer invalid err=3")
        if MODE == "no-mmap":
            raise SystemError("<method 'poll' of 'linuxcnc.stat' objects> returned NULL")
        self.joints = 3
        self.homed = (1, 1, 1, 0, 0, 0, 0, 0, 0)
        self.interp_state = INTERP_IDLE
        self.task_state = STATE_ESTOP if MODE == "estop" else STATE_ON


class ini:
    """LinuxCNC's INI reader as the screens use it: find(SECTION, KEY), the first value or None
    (the real one raises linuxcnc.error for a file it cannot open)."""

    def __init__(self, path):
        try:
            with open(path) as f:
                self.lines = [line.strip() for line in f]
        except OSError:
            raise error("inifile.open() failed") from None

    def find(self, section, key):
        current = None
        for line in self.lines:
            if line.startswith("[") and line.endswith("]"):
                current = line[1:-1]
            elif current == section and "=" in line:
                name, _, value = line.partition("=")
                if name.strip() == key:
                    return value.strip()
        return None
