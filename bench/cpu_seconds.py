#!/usr/bin/env python3
"""CPU seconds (user + system) of one run of a command, from wait4's rusage (microseconds; GNU
time's %U/%S round to 10 ms, a third of the smallest SPD scene's render). The command's output
is discarded; exits 1 when the command fails. Used by bench/peers.sh and bench/ab_render.sh.

    usage: bench/cpu_seconds.py COMMAND [ARGS...]
"""
import os
import sys

if len(sys.argv) < 2:
    sys.exit(__doc__)
pid = os.fork()
if pid == 0:
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 1)
    os.dup2(null, 2)
    os.execvp(sys.argv[1], sys.argv[1:])
_, status, usage = os.wait4(pid, 0)
if os.waitstatus_to_exitcode(status) != 0:
    sys.exit(1)
print("%.4f" % (usage.ru_utime + usage.ru_stime))
