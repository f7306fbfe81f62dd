"""Test-suite settings: solvers run uncompiled (compiling each problem would take minutes);
tests/test_codegen.py turns compilation on, with its own cache directory."""

import os

os.environ.setdefault("AUVDOCK_COMPILE", "never")
