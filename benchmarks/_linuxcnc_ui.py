#!/usr/bin/python3
"""A headless LinuxCNC display for ``benchmarks/linuxcnc_start.py``: LinuxCNC starts it as its
``[DISPLAY]DISPLAY`` program (``DISPLAY -ini INIFILE``), and it drives the machine through
LinuxCNC's own Python interface (``linuxcnc.command``/``stat``), as its regression tests do.

It takes the machine out of E-stop, turns it on, homes every joint, reads the world position
genhexkins' forward kinematics gives at the joint homes, then runs each MDI move of
``STEWART_JAX_LINUXCNC_MOVES`` (a JSON list of G-code lines) and reads back the joint positions
(strut lengths, mm) and the world position (mm, degrees). Everything it saw is written as JSON to
``STEWART_JAX_LINUXCNC_OUT``; on leaving it puts the machine back in E-stop, and LinuxCNC shuts
down. Runs with the system Python that LinuxCNC's ``linuxcnc`` module is built for.
"""

import json
import os
import signal
import sys
import time

import linuxcnc

TIMEOUT_S = float(os.environ.get("STEWART_JAX_LINUXCNC_TIMEOUT", "90"))
out = {"errors": [], "moves": []}


def _give_up(signum, frame):
    raise TimeoutError(f"the LinuxCNC session did not finish in {TIMEOUT_S} s")


def main() -> None:
    s, c, err = linuxcnc.stat(), linuxcnc.command(), linuxcnc.error_channel()

    def drain():
        while True:
            m = err.poll()
            if not m:
                return
            out["errors"].append(str(m[1]))

    def until(done, seconds, what):
        t0 = time.time()
        while time.time() - t0 < seconds:
            s.poll()
            if done():
                return
            time.sleep(0.05)
        drain()
        raise RuntimeError(f"{what} did not happen in {seconds} s (errors: {out['errors']})")

    for state, done in ((linuxcnc.STATE_ESTOP_RESET, lambda: s.task_state != linuxcnc.STATE_ESTOP),
                        (linuxcnc.STATE_ON, lambda: s.task_state == linuxcnc.STATE_ON)):
        c.state(state)
        c.wait_complete(10)
        until(done, 20, f"task state {state}")
    c.mode(linuxcnc.MODE_MANUAL)
    c.wait_complete(10)
    c.teleop_enable(0)
    c.wait_complete(10)
    c.home(-1)
    c.wait_complete(10)
    until(lambda: all(s.homed[:6]), 30, "homing")
    out["homed_joints_mm"] = list(s.joint_actual_position[:6])
    out["homed_position"] = list(s.actual_position[:6])
    c.mode(linuxcnc.MODE_MDI)
    c.wait_complete(10)
    for line in json.loads(os.environ.get("STEWART_JAX_LINUXCNC_MOVES", "[]")):
        before = len(out["errors"])
        c.mdi(line)
        c.wait_complete(60)
        until(lambda: s.interp_state == linuxcnc.INTERP_IDLE and s.inpos, 60, f"the move {line!r}")
        time.sleep(0.2)  # an interpreter error reaches the error channel after the idle state
        drain()
        s.poll()
        out["moves"].append({"mdi": line, "joints_mm": list(s.joint_actual_position[:6]),
                             "position": list(s.actual_position[:6]), "errors": out["errors"][before:]})
    drain()


if __name__ == "__main__":
    signal.signal(signal.SIGALRM, _give_up)
    signal.alarm(int(TIMEOUT_S))
    try:
        main()
        out["ok"] = True
    except Exception as e:  # noqa: BLE001 - everything goes to the JSON the caller reads
        out["ok"] = False
        out["failure"] = f"{type(e).__name__}: {e}"
    finally:
        signal.alarm(0)
        with open(os.environ.get("STEWART_JAX_LINUXCNC_OUT", "linuxcnc_ui.json"), "w") as f:
            json.dump(out, f)
        try:
            cmd = linuxcnc.command()
            cmd.state(linuxcnc.STATE_ESTOP)
            cmd.wait_complete(5)
        except Exception:  # noqa: BLE001 - shutting down anyway
            pass
    sys.exit(0 if out["ok"] else 1)
