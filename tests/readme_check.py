#!/usr/bin/env python3
"""Runs every command block of README.md, in order, as a new user would, and fails on the first
command that does not succeed.

Usage: readme_check.py README.md BTFGMM_BINARY SOURCE_DIR

The commands run in one empty temporary folder holding a link to the source tree's examples/,
at small sizes so that the whole README takes seconds: `generate` renders fewer directions,
a fit takes at most MAX_COMPONENTS components and a sweep two iterations a fit (every other
option as written). A fit --budget runs as written, at full size: on the README's data
generated again as written (every direction), so that the budget's answer is the user's.
Lines that
are not commands of the tool (`make ...`) and indented comment lines are skipped. A fit
whose checkpoint a later command resumes is interrupted with SIGINT, as the README says a
user's Ctrl-C does, once its first checkpoint is written. Python (a `python3 -c` line, a
```python block) runs with the built module on PYTHONPATH, where it was built.
"""
import glob
import os
import re
import shlex
import signal
import subprocess
import sys
import tempfile
import time

MAX_COMPONENTS = 100
PYTHON_BLOCK = "<python>"
PYTHON_LINES = ("python3 -c ", "/usr/bin/python3 -c ")  # a one-line program, run as a block
SWEEP_ITERATIONS = ["--iterations", "2"]  # every fit of a sweep, unless set
SMALL_GENERATE = ["--lights", "spiral:9", "--views", "spiral:4", "--supersample", "1"]


def command_lines(readme_text):
    """The README's commands, in order: each unindented line of its unlabelled code blocks, and
    each ```python block whole (as one entry starting with PYTHON_BLOCK)."""
    lines, block, fence = [], [], None  # fence: None outside, else the opening's label
    for raw in readme_text.splitlines():
        if raw.startswith("```"):
            if fence is None:
                fence, block = raw.strip()[3:], []
            else:
                if fence == "python":
                    lines.append(PYTHON_BLOCK + "\n".join(block))
                fence = None
            continue
        if fence == "python":
            block.append(raw)
            continue
        if fence != "" or not raw.strip() or raw[0].isspace() or raw.startswith("#"):
            continue
        lines.append(raw)
    return lines


def run_python(code, work, python_path):
    """Runs Python code of the README with the built module; False where it was not built."""
    if not glob.glob(os.path.join(python_path, "btfgmm*.so")):
        return False
    code = re.sub(r"components=(\d+)",
                  lambda m: f"components={min(int(m.group(1)), MAX_COMPONENTS)}", code)
    env = dict(os.environ, PYTHONPATH=python_path)
    done = subprocess.run(["/usr/bin/python3", "-c", code], cwd=work, env=env,
                          capture_output=True, timeout=600)
    if done.returncode != 0:
        sys.exit(f"FAIL (exit {done.returncode}): the README's Python:\n{code}\n"
                 f"{done.stderr.decode()}{done.stdout.decode()[-2000:]}")
    return True


def words_of(line):
    """The command's words without its trailing comment."""
    return shlex.split(line, comments=True)


def smaller(words):
    """The command at test size: fewer directions, at most MAX_COMPONENTS components."""
    out = list(words)
    for i, w in enumerate(out[:-1]):
        if w in ("--components", "-M") and int(out[i + 1]) > MAX_COMPONENTS:
            out[i + 1] = str(MAX_COMPONENTS)
    if len(out) > 1 and out[1] == "generate":
        out += SMALL_GENERATE
    # A mixture fit at its default M: at most MAX_COMPONENTS (the test's tile is small).
    mixture_fit = out[1:2] == ["fit"] and option(out, "--method") in (None, "gm") and not (
        {"-M", "--components", "--resume", "--continue", "--budget", "--ratio"} & set(out))
    if mixture_fit:
        out += ["--components", str(MAX_COMPONENTS)]
    if out[1:2] == ["sweep"] and "--iterations" not in out:
        out += SWEEP_ITERATIONS
    return out


def at_full_size(words):
    """A fit --budget (or --ratio): run as written, on data generated as written."""
    return words[1:2] == ["fit"] and ("--budget" in words or "--ratio" in words)


def full_size_data(words, generated, work):
    """The command with its data (the word after `fit`) replaced by a full-size copy, which
    the README's own generate line for that folder writes (once) as written."""
    data = words[2]
    made = generated.get(data.rstrip("/"))
    if made is None:
        return words
    full = data.rstrip("/") + "-full-size/"
    if not os.path.exists(os.path.join(work, full)):
        argv = list(made)
        argv[argv.index("-o" if "-o" in argv else "--output") + 1] = full
        subprocess.run(argv, cwd=work, check=True, capture_output=True, timeout=600)
    return words[:2] + [full] + words[3:]


def option(words, name):
    return words[words.index(name) + 1] if name in words else None


def run_interrupted(argv, checkpoint, cwd):
    """Starts a fit, sends SIGINT once its checkpoint exists; the checkpoint must remain."""
    proc = subprocess.Popen(argv, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    path = os.path.join(cwd, checkpoint)
    while proc.poll() is None and not os.path.exists(path):
        time.sleep(0.005)
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=600)
    if not os.path.exists(path):
        sys.exit(f"FAIL: the fit ended (exit {proc.returncode}) before it could be interrupted, "
                 f"or left no checkpoint {checkpoint}:\n{err.decode()}")
    return proc.returncode


def main():
    readme, binary, source = sys.argv[1], os.path.abspath(sys.argv[2]), os.path.abspath(sys.argv[3])
    commands = command_lines(open(readme, encoding="utf-8").read())
    if len(commands) < 20:
        sys.exit(f"FAIL: only {len(commands)} commands found in {readme}; is the parser wrong?")
    resumed = {option(words_of(c), "--resume") for c in commands} - {None}
    ran = 0
    with tempfile.TemporaryDirectory(prefix="btfgmm_readme_") as work:
        os.symlink(os.path.join(source, "examples"), os.path.join(work, "examples"))
        python_path = os.path.join(os.path.dirname(binary), "python")
        generated = {}  # each folder the README generates: its generate command as written
        for line in commands:
            start = time.time()
            if line.startswith(PYTHON_BLOCK) or line.startswith(PYTHON_LINES):
                code = line[len(PYTHON_BLOCK):] if line.startswith(PYTHON_BLOCK) else words_of(line)[2]
                note = "ok" if run_python(code, work, python_path) else "skipped: no module"
                print(f"{time.time() - start:6.2f} s  {note:18s} python: {code.splitlines()[0][:80]}")
                continue
            words = words_of(line)
            if words[0] == "make":
                continue
            if words[0] != "btfgmm":
                sys.exit(f"FAIL: README command is not btfgmm's: {line}")
            if words[1] == "generate":
                generated[(option(words, "-o") or option(words, "--output")).rstrip("/")] = (
                    [binary] + words[1:])
            argv = ([binary] + full_size_data(words, generated, work)[1:] if at_full_size(words)
                    else [binary] + smaller(words)[1:])
            checkpoint = option(words, "--checkpoint")
            if words[1] == "fit" and checkpoint in resumed:
                code = run_interrupted(argv, checkpoint, work)
                note = f"interrupted, exit {code}"
            else:
                done = subprocess.run(argv, cwd=work, capture_output=True, timeout=600)
                if done.returncode != 0:
                    sys.exit(f"FAIL (exit {done.returncode}): {line}\n  ran: {shlex.join(argv)}\n"
                             f"{done.stderr.decode()}{done.stdout.decode()[-2000:]}")
                note = "ok, full size" if at_full_size(words) else "ok"
            ran += 1
            print(f"{time.time() - start:6.2f} s  {note:18s} {line[:100]}")
    print(f"README: {ran} commands ran in order")


if __name__ == "__main__":
    main()
