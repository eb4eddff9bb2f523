#!/usr/bin/env python3
"""Ctrl-C at every stage of the long commands: each must end within STOP_SECONDS and leave what it
promises (a complete model or checkpoint for a fit, the models fitted so far for a sweep, no
half-written file for decode and render).

Usage: sigint_check.py BTFGMM_BINARY

Each case starts a command on a small generated BTF, waits until its stderr shows the stage
(a progress line), sends SIGINT, and measures the time to its exit. The stages are made long on
purpose (many components, a large render) so that a stage without a check for the stop would
run for minutes after the signal.
"""
import os
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time

STOP_SECONDS = 10.0  # from the signal to the exit
START_TIMEOUT = 300.0  # for the stage to be reached at all


def run_until(argv, cwd, pattern, delay=0.0):
    """Starts argv, sends SIGINT `delay` s after a stderr line matches `pattern`; returns
    (exit status, seconds from the signal to the exit, stderr)."""
    proc = subprocess.Popen(argv, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True, bufsize=1)
    lines, seen = [], threading.Event()

    def read():
        for line in proc.stderr:
            lines.append(line)
            if re.search(pattern, line):
                seen.set()
        seen.set()  # the stream ended

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    if pattern is None:  # a command that prints nothing before its end: `delay` s after start
        seen.set()
    if not seen.wait(START_TIMEOUT) or proc.poll() is not None:
        proc.kill()
        sys.exit(f"FAIL: {' '.join(argv)}: never reached /{pattern}/ (exit {proc.poll()}):\n"
                 + "".join(lines[-20:]))
    time.sleep(delay)
    sent = time.time()
    proc.send_signal(signal.SIGINT)
    try:
        code = proc.wait(timeout=120)
    except subprocess.TimeoutExpired:
        proc.kill()
        sys.exit(f"FAIL: {' '.join(argv)}: still running 120 s after SIGINT at /{pattern}/:\n"
                 + "".join(lines[-20:]))
    took = time.time() - sent
    reader.join(5)
    return code, took, "".join(lines)


def check(name, code, took, err, want_codes=(130, -signal.SIGINT)):
    if took > STOP_SECONDS:
        sys.exit(f"FAIL: {name}: exited {took:.1f} s after SIGINT (at most {STOP_SECONDS} s)\n"
                 + err[-3000:])
    if code not in want_codes:
        sys.exit(f"FAIL: {name}: exit status {code} after SIGINT, expected one of {want_codes}\n"
                 + err[-3000:])
    print(f"ok  {name}: exit {code} {took:.2f} s after SIGINT")


def must_succeed(argv, cwd):
    done = subprocess.run(argv, cwd=cwd, capture_output=True, text=True, timeout=600)
    if done.returncode != 0:
        sys.exit(f"FAIL: {' '.join(argv)} (exit {done.returncode}):\n{done.stderr[-3000:]}")
    return done.stdout


def no_partial_files(folder, name):
    """No temporary file of an atomic write is left where the command writes."""
    for root, _, files in os.walk(folder):
        for f in files:
            if ".tmp" in f or f.startswith(".btfgmm"):
                sys.exit(f"FAIL: {name}: a partial file was left: {os.path.join(root, f)}")


def main():
    btfgmm = os.path.abspath(sys.argv[1])
    with tempfile.TemporaryDirectory(prefix="btfgmm_sigint_") as work:
        must_succeed([btfgmm, "generate", "--material", "knit", "--size", "16", "--seed", "2",
                      "--lights", "spiral:36", "--views", "spiral:25", "-q", "-o", "btf"], work)
        fit = [btfgmm, "fit", "btf", "--tile", "0,0,16,16", "--seed", "1"]

        # EM: the iteration under way ends, its state is saved; --resume takes it on.
        code, took, err = run_until(fit + ["-M", "400", "--iterations", "200",
                                           "--checkpoint", "em.ckpt", "-o", "em.btfgmm"],
                                    work, r"^iteration +2/")
        check("fit, in EM", code, took, err, (130,))
        must_succeed([btfgmm, "fit", "--resume", "em.ckpt", "--iterations", "3"], work)
        must_succeed([btfgmm, "info", "em.btfgmm"], work)

        # The colour refit after EM: with many components its normal equations are the work.
        code, took, err = run_until(fit + ["-M", "2000", "--iterations", "1",
                                           "-o", "refit.btfgmm"],
                                    work, r"^iteration +1/1")
        check("fit, in the colour refit", code, took, err, (130,))
        must_succeed([btfgmm, "info", "refit.btfgmm"], work)

        # The refinement's steps: the best model met is written, complete.
        code, took, err = run_until(fit + ["-M", "200", "--iterations", "2",
                                           "--refine-steps", "100000", "-o", "refine.btfgmm"],
                                    work, r"^refin", delay=2.0)
        check("fit, in the refinement", code, took, err, (130,))
        must_succeed([btfgmm, "info", "refine.btfgmm"], work)

        # Another method's fit (LPCA's rounds), a sweep, and the budget's candidates.
        code, took, err = run_until(fit + ["--method", "lpca", "--clusters", "64",
                                           "--components", "8", "-o", "lpca.btfgmm"],
                                    work, r"^lpca +0")
        check("fit --method lpca", code, took, err)
        # The neural BTF's epochs: the lowest held-out error met is written, complete, and its
        # provenance says the fit was stopped; its state is saved, and --resume takes it on.
        code, took, err = run_until(fit + ["--method", "neural", "--width", "256",
                                           "--iterations", "1000", "--checkpoint", "neural.ckpt",
                                           "-o", "neural.btfgmm"],
                                    work, r"^neural .*epoch 1 of")
        check("fit --method neural", code, took, err, (130,))
        info = subprocess.run([btfgmm, "info", "neural.btfgmm"], cwd=work, capture_output=True,
                              text=True)
        if info.returncode != 0 or "stopped by the user" not in info.stdout:
            sys.exit("fit --method neural: the model of a stopped fit is not written, or its "
                     "provenance does not say it was stopped:\n" + info.stdout + info.stderr)
        if "fit --resume neural.ckpt" not in err:
            sys.exit("fit --method neural: a stopped fit does not say how to go on:\n" + err)
        must_succeed([btfgmm, "fit", "--resume", "neural.ckpt", "--iterations", "3"], work)
        if os.path.exists(os.path.join(work, "neural.ckpt")):
            sys.exit("fit --resume of a neural fit: the checkpoint is kept after the model")
        code, took, err = run_until([btfgmm, "sweep", "btf", "--tile", "0,0,16,16",
                                     "-o", "sweep"], work, r"%|fitting|gm", delay=1.0)
        check("sweep", code, took, err)

        # decode and render: no half-written file.
        must_succeed(fit + ["-M", "100", "--iterations", "2", "--objective", "likelihood",
                            "-q", "-o", "small.btfgmm"], work)
        os.mkdir(os.path.join(work, "decoded"))
        code, took, err = run_until([btfgmm, "decode", "small.btfgmm", "-o", "decoded",
                                     "--size", "512", "--overwrite"], work, r".", delay=1.0)
        check("decode", code, took, err)
        no_partial_files(os.path.join(work, "decoded"), "decode")
        code, took, err = run_until([btfgmm, "render", "small.btfgmm", "--mesh", "sphere",
                                     "--size", "6000x6000", "-o", "big.png"],
                                    work, None, delay=0.5)
        check("render", code, took, err)
        no_partial_files(work, "render")
    print("every stage stopped within", STOP_SECONDS, "s of SIGINT")


if __name__ == "__main__":
    main()
