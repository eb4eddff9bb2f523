#!/usr/bin/env python3
"""Every program the build, the tests and the scripts run is installed by scripts/install-deps.

    tests/install_deps_check.py SOURCE_DIR

Reads the package list of scripts/install-deps, then finds the programs each script runs:
the commands of the shell scripts (scripts/*, bench/*.sh, tests/*.sh, .ci/run), of the
Makefile's recipes and $(shell ...) calls, of CMake's add_test/execute_process COMMANDs, of
the README's shell blocks, and the interpreters and subprocesses of tests/*.py. Each program
found must be in PROGRAMS below, and the Debian package PROGRAMS names for it must be one
scripts/install-deps installs, or one of every Debian system (BASE). Fails, naming the file
and line and what to add, for a program nobody listed or a package install-deps lacks.

The scan is a reader of the scripts as they are written here, not a shell parser: a command
reached only through a variable ("$browser") is not seen, so such programs are listed in
PROGRAMS by hand, with the file that runs them.
"""

import os
import re
import shlex
import sys

# The packages of every Debian system: those of priority "required", which a minimal install
# (debootstrap --variant=minbase, the Debian container images) holds.
BASE = {
    "apt", "base-files", "bash", "bsdutils", "coreutils", "dash", "debianutils", "diffutils",
    "dpkg", "findutils", "grep", "gzip", "hostname", "login", "mawk", "mount", "ncurses-bin",
    "perl-base", "sed", "sysvinit-utils", "tar", "util-linux",
}

# Shell builtins and keywords: no program behind them. (`time` the keyword is bash's; the
# program /usr/bin/time is the Debian package time, listed below by its path.)
BUILTINS = {
    "[", "[[", "]]", "!", "{", "}", ".", ":", "alias", "break", "case", "cd", "command",
    "continue", "declare", "do", "done", "echo", "elif", "else", "esac", "eval", "exec", "exit",
    "export", "false", "fi", "for", "function", "getopts", "if", "in", "local", "printf",
    "pwd", "read", "readonly", "return", "select", "set", "shift", "source", "test", "then",
    "time", "trap", "true", "type", "ulimit", "umask", "unset", "until", "wait", "while",
    "kill",
}

# Program -> the Debian package that installs it. Where a program is run through a variable
# or from C++ (the scan does not see those), the comment names who runs it.
PROGRAMS = {
    # Debian's base system (BASE)
    "apt-get": "apt",
    "awk": "mawk",
    "basename": "coreutils", "cat": "coreutils", "cp": "coreutils", "cut": "coreutils",
    "date": "coreutils", "dirname": "coreutils", "du": "coreutils", "env": "coreutils", "head": "coreutils",
    "id": "coreutils", "ln": "coreutils", "ls": "coreutils", "mkdir": "coreutils",
    "mktemp": "coreutils", "mv": "coreutils", "nice": "coreutils", "nproc": "coreutils",
    "realpath": "coreutils", "rm": "coreutils", "sh": "dash", "sleep": "coreutils",
    "seq": "coreutils", "sort": "coreutils", "stat": "coreutils", "tail": "coreutils", "tee": "coreutils", "timeout": "coreutils",
    "touch": "coreutils", "tr": "coreutils", "uniq": "coreutils", "wc": "coreutils",
    "bash": "bash",
    "dpkg-query": "dpkg",
    "cmp": "diffutils",
    "find": "findutils", "xargs": "findutils",
    "grep": "grep",
    "sed": "sed",
    "taskset": "util-linux",
    "which": "debianutils",
    # the build
    "cmake": "cmake", "ctest": "cmake",
    "make": "make",
    "g++": "g++",
    "pkg-config": "pkg-config",
    "clang++": "clang",  # scripts/fuzz: the libFuzzer targets
    "clang-format": "clang-format",  # make format
    "git": "git",  # make format (git ls-files); bench/bench-em-history.sh (git worktree)
    # the tests and benchmarks
    "python3": "python3",  # tests/*.py, bench/*.sh, the README's Python
    "/usr/bin/python3": "python3",
    "/usr/bin/time": "time",  # bench/bench-scale.sh: each run's peak memory (time -v)
    "hyperfine": "hyperfine",  # bench/bench-em-history.sh, bench/bench-render-process.sh
    "uptime": "procps",  # bench/bench-render-process.sh: the load beside each round's times
    "mpirun": "openmpi-bin",  # bench/bench-scale.sh; tests/test_scale.cpp (CMake's MPIEXEC)
    "mpiexec": "openmpi-bin",
    "chromium": "chromium",  # scripts/report-screenshot ("$browser"), tests/test_view.cpp
    # Programs a script calls only where something is missing, to install it (with root)
    "sudo": None,
}

# Programs the scan must find, so that a scanner broken by a change of the scripts fails
# here instead of passing on nothing.
MUST_FIND = {"/usr/bin/time", "hyperfine", "python3", "cmake", "mpirun", "apt-get", "git"}

# Why a program maps to no package: it is what installs the packages, so a machine without
# it is told to run the script as root (scripts/install-deps says so).
NO_PACKAGE = {"sudo": "install-deps runs as root, or through sudo where there is one"}

# Words that run the rest of the line as the command: `nice -n 10 cmd`, `sudo cmd`, ...
PREFIXES = {"exec": 0, "command": 0, "nice": None, "sudo": 0, "env": 0, "timeout": 1, "!": 0}


def install_deps_packages(source):
    """The packages scripts/install-deps installs (its `packages=( ... )` array)."""
    text = open(os.path.join(source, "scripts", "install-deps"), encoding="utf-8").read()
    m = re.search(r"^packages=\((.*?)^\)", text, re.S | re.M)
    if not m:
        sys.exit("FAIL: no packages=( ... ) array in scripts/install-deps; is the parser wrong?")
    words = []
    for line in m.group(1).splitlines():
        words += line.split("#", 1)[0].split()
    return set(words)


def strip_comment(line):
    """The line without its comment (a # at a word's start, outside quotes)."""
    quote = None
    for i, c in enumerate(line):
        if quote:
            if c == quote:
                quote = None
            elif c == "\\" and quote == '"':
                continue
        elif c in "'\"":
            quote = c
        elif c == "#" and (i == 0 or line[i - 1] in " \t;(") and not line[i - 1 : i + 1] == "$#":
            return line[:i]
    return line


def substitutions(text):
    """The bodies of $( ... ) and ` ... ` in `text` (outside single quotes), and the text with
    each replaced by a placeholder word."""
    bodies, out, i, quote = [], [], 0, None
    while i < len(text):
        c = text[i]
        if quote == "'":
            out.append(c)
            if c == "'":
                quote = None
            i += 1
            continue
        if c == "'" and quote is None:
            quote = "'"
        elif c == '"':
            quote = None if quote == '"' else '"'
        if text.startswith("$((", i):  # arithmetic, not a command
            depth, j = 0, i + 1
            while j < len(text):
                depth += {"(": 1, ")": -1}.get(text[j], 0)
                j += 1
                if depth == 0:
                    break
            out.append("0")
            i = j
            continue
        if text.startswith("$(", i):
            depth, j = 1, i + 2
            while j < len(text) and depth:
                depth += {"(": 1, ")": -1}.get(text[j], 0)
                j += 1
            bodies.append(text[i + 2 : j - 1])
            out.append("SUBST")
            i = j
            continue
        out.append(c)
        i += 1
    return bodies, "".join(out)


def command_words(script):
    """(line number, program) for each simple command of a shell script."""
    found = []
    lines = script.split("\n")
    heredoc, array, cases = None, False, 0
    logical, start = "", 0
    for n, raw in enumerate(lines, 1):
        if heredoc:
            if raw.strip() == heredoc:
                heredoc = None
            continue
        line = strip_comment(raw)
        if array:  # the words of a multi-line array assignment, up to its ")"
            array = ")" not in line
            line = line.split(")", 1)[1] if ")" in line else ""
        elif re.search(r"^\s*[A-Za-z_]\w*\+?=\([^)]*$", line):
            array, line = True, ""
        cases += len(re.findall(r"^\s*case\s|[;&|]\s*case\s", line))
        cases -= len(re.findall(r"\besac\b", line))
        if cases and not logical:  # a case pattern starting the line: "-h | --help) ..."
            line = re.sub(r"^\s*\(?[^()]*?\)", "", line, count=1)
        m = re.search(r"<<-?\s*['\"]?(\w+)['\"]?", line)
        if m:
            heredoc = m.group(1)
        if not logical:
            start = n
        if line.rstrip().endswith("\\"):
            logical += line.rstrip()[:-1] + " "
            continue
        logical += line
        found += [(start + k, w) for k, w in commands_of(logical)]
        logical = ""
    return found


def commands_of(text):
    """(0, program) for each simple command of one logical line (0: the line's offset)."""
    bodies, rest = substitutions(text)
    rest = re.sub(r"\(\((.*?)\)\)", " 0 ", rest)  # arithmetic: (( i++ )), for ((i = 0; ...))
    found = []
    for b in bodies:
        found += commands_of(b)
    lexer = shlex.shlex(rest, posix=True, punctuation_chars=";&|()<>")
    lexer.whitespace_split = True
    lexer.commenters = ""
    try:
        tokens = list(lexer)
    except ValueError:  # an unclosed quote: a multi-line string, not read here
        return found
    at_start, skip, case_pattern = True, 0, False
    for i, t in enumerate(tokens):
        if t == "=":
            continue
        if set(t) <= set(";&|()<>"):
            at_start = t not in ("<", ">", "<<", ">>", ">&", "<&") or at_start
            if t in (";;", ";&"):
                case_pattern = True
            if t == ")" and case_pattern:
                case_pattern = False
            continue
        if i > 0 and tokens[i - 1] in ("<", ">", ">>", "<<", ">&", "2>", "&>"):
            continue  # a redirection's file
        if t.isdigit() and i + 1 < len(tokens) and tokens[i + 1][0] in "<>":
            continue  # the descriptor of a redirection: 2>/dev/null
        if t.endswith("=") and i + 1 < len(tokens) and tokens[i + 1] == "(":
            while i + 1 < len(tokens) and tokens[i + 1] != ")":
                tokens[i + 1] = "="  # an array assignment's words: not commands
                i += 1
            at_start = False
            continue
        if not at_start:
            if t in ("-c",) and tokens[i - 1] in ("sh", "bash"):
                if i + 1 < len(tokens):
                    found += commands_of(tokens[i + 1])
            continue
        if case_pattern or t in ("in",):
            continue
        if re.match(r"^[A-Za-z_][A-Za-z0-9_]*(\[[^]]*\])?\+?=", t):
            continue  # an assignment before the command
        if re.match(r"^\d*[<>]", t):
            continue  # a redirection
        if skip:
            skip -= 1
            continue
        if t in ("if", "then", "do", "else", "elif", "while", "until", "{", "!", "time"):
            continue
        if re.fullmatch(r"\$\{\w+\[@\]\}", t):
            continue  # an array of prefix words: "${as_root[@]}" apt-get ...
        if t in PREFIXES:
            found.append((0, t))
            if t == "nice" and i + 2 < len(tokens) and tokens[i + 1] == "-n":
                skip = 2
            elif t == "command" and i + 1 < len(tokens) and tokens[i + 1] == "-v":
                skip = 1  # `command -v X` asks for X: X is counted as a program
            elif PREFIXES[t]:
                skip = PREFIXES[t]
            continue
        if t in ("for", "case", "function"):
            at_start = False
            if t == "case":
                case_pattern = False
            continue
        found.append((0, t))
        at_start = False
    return found


def shell_files(source):
    files = []
    for folder, pattern in (("scripts", None), ("bench", r"\.sh$"), ("tests", r"\.sh$")):
        d = os.path.join(source, folder)
        for name in sorted(os.listdir(d)):
            path = os.path.join(d, name)
            if not os.path.isfile(path) or (pattern and not re.search(pattern, name)):
                continue
            head = open(path, encoding="utf-8", errors="replace").readline()
            if pattern or re.search(r"\b(ba)?sh\b", head):
                files.append(path)
    files.append(os.path.join(source, ".ci", "run"))
    return files


def makefile_script(text):
    """The Makefile as shell text: its recipes and $(shell ...) calls, make's own references
    replaced by a placeholder word."""
    lines = []
    for raw in text.replace("\\\n", " ").split("\n"):
        for m in re.finditer(r"\$\(shell ([^()]*(\([^()]*\))*[^()]*)\)", raw):
            lines.append(m.group(1))
        if raw.startswith("\t"):
            line = raw[1:].lstrip("@-+ ")
            line = re.sub(r"\$\((MAKE)\)", "make", line)
            line = re.sub(r"\$\([A-Za-z_]+[^()]*(\([^()]*\))*[^()]*\)", "MAKEVAR", line)
            lines.append(line.replace("$$", "$"))
        else:
            lines.append("")
    return "\n".join(lines)


def defined_functions(script):
    return set(re.findall(r"^\s*(?:function\s+)?([A-Za-z_][\w-]*)\s*\(\)\s*\{", script, re.M))


def programs_in(source):
    """(file, line, program) for every program the repository's scripts run."""
    def rel(path):
        return os.path.relpath(path, source)

    out = []
    for path in shell_files(source):
        script = open(path, encoding="utf-8").read()
        own = defined_functions(script)
        head = script.split("\n", 1)[0]
        m = re.match(r"#!\s*(?:/usr/bin/env\s+)?(\S+)", head)
        if m:
            out.append((rel(path), 1, m.group(1)))
        out += [(rel(path), n, w) for n, w in command_words(script) if w not in own]
    mk = os.path.join(source, "Makefile")
    out += [("Makefile", n, w) for n, w in command_words(makefile_script(open(mk).read()))]
    for cm in ("CMakeLists.txt", "python/CMakeLists.txt"):
        text = open(os.path.join(source, cm), encoding="utf-8").read()
        targets = set(re.findall(r"add_executable\((\w+)", text))
        for m in re.finditer(r"\bCOMMAND\s+(\S+)", text):
            n = text.count("\n", 0, m.start()) + 1
            if m.group(1) not in targets:
                out.append((cm, n, m.group(1)))
    readme = open(os.path.join(source, "README.md"), encoding="utf-8").read()
    for block in re.finditer(r"^```(?:sh|bash|console)\n(.*?)^```", readme, re.S | re.M):
        first = readme.count("\n", 0, block.start(1)) + 1
        out += [("README.md", first + n - 1, w) for n, w in command_words(block.group(1))]
    tests = os.path.join(source, "tests")
    for name in sorted(os.listdir(tests)):
        if not name.endswith(".py"):
            continue
        text = open(os.path.join(tests, name), encoding="utf-8").read()
        m = re.match(r"#!\s*(?:/usr/bin/env\s+)?(\S+)", text)
        if m:
            out.append(("tests/" + name, 1, m.group(1)))
        call = r"subprocess\.\w+\(\s*\[\s*\"([^\"]+)\"|shutil\.which\(\s*\"([^\"]+)\""
        for m in re.finditer(call, text):
            n = text.count("\n", 0, m.start()) + 1
            out.append(("tests/" + name, n, m.group(1) or m.group(2)))
    return out


def is_project_or_dynamic(word):
    """A word that is not a program to install: a variable, a CMake expression, a placeholder
    for a substitution, or a file of this repository or of its builds."""
    if any(c in word for c in "$<>*") or word.startswith(("SUBST", "MAKEVAR")) or word == "0":
        return True
    if word.startswith(("./", "build", "scripts/", "bench/", "tests/", "python/", "cli/")):
        return True
    return word in ("btfgmm",)  # the README's command: the program this repository builds


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: install_deps_check.py SOURCE_DIR")
    source = os.path.abspath(sys.argv[1])
    packages = install_deps_packages(source)
    if len(packages) < 10:
        sys.exit(f"FAIL: only {len(packages)} packages read from scripts/install-deps")
    failures = []
    seen = {}
    for path, line, word in programs_in(source):
        if word in BUILTINS or is_project_or_dynamic(word):
            continue
        seen.setdefault(word, f"{path}:{line}")
        if word not in PROGRAMS:
            failures.append(f"{path}:{line} runs '{word}', which tests/install_deps_check.py "
                            "does not know: add it to PROGRAMS with its Debian package, and "
                            "the package to scripts/install-deps")
    for program, package in sorted(PROGRAMS.items()):
        if package is None:
            if program not in NO_PACKAGE:
                failures.append(f"'{program}' has no package and no reason in NO_PACKAGE")
        elif package not in packages and package not in BASE:
            where = seen.get(program, "listed in PROGRAMS")
            failures.append(f"'{program}' ({where}) needs the Debian package {package}, which "
                            "scripts/install-deps does not install: add it to its packages")
    print(f"{len(seen)} programs found in the scripts: {' '.join(sorted(seen))}")
    if MUST_FIND - set(seen):
        failures.append(f"the scan did not find {' '.join(sorted(MUST_FIND - set(seen)))}, "
                        "which the scripts run; is the scanner wrong?")
    for f in failures:
        print("FAIL: " + f)
    if not failures:
        print(f"every program is installed by scripts/install-deps ({len(packages)} packages) "
              "or comes with Debian's base system")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
