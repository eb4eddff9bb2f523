#!/usr/bin/env python3
"""Runs the Python module's pytest suite for CTest (test `python_module`).

usage: run_pytest.py MODULE_DIR BTFGMM_COMMAND   (the built module's folder, the built command)
       run_pytest.py --skip REASON               (the suite cannot run: reported skipped)

Exits 77, which CTest reports as skipped, where the module or the command was not built or
pytest or numpy is absent; otherwise pytest's status.
"""
import os
import sys

SKIP = 77


def main(argv):
    if len(argv) == 3 and argv[1] == "--skip":
        print(f"skipped: {argv[2]}")
        return SKIP
    if len(argv) != 3:
        print(__doc__)
        return 2
    for name in ("pytest", "numpy"):
        try:
            __import__(name)
        except ImportError:
            print(f"skipped: {name} is not installed for {sys.executable} (Debian "
                  f"python3-{name})")
            return SKIP
    import pytest

    os.environ["BTFGMM_CLI"] = argv[2]
    sys.path.insert(0, argv[1])
    here = os.path.dirname(os.path.abspath(__file__))
    return pytest.main(["-q", "-p", "no:cacheprovider", here])


if __name__ == "__main__":
    sys.exit(main(sys.argv))
