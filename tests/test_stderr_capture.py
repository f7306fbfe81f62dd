"""What C code prints to fd 2 during a controller step is counted, not shown."""

from __future__ import annotations

import os

from auvdock.runtime.stderr_capture import StderrCapture


def test_fd2_output_is_counted_and_new_lines_reported(capfd) -> None:
    seen: list[str] = []
    cap = StderrCapture(on_new=seen.append, max_distinct=2)
    for k in range(3):  # CasADi stamps each line with the time: still one kind
        with cap.capture():
            os.write(2, b"CasADi - 2026-11-30 20:34:5%d WARNING: qrqp failed\nsecond line\n" % k)
    with cap.capture():
        os.write(2, b"a third kind\n")
    cap.close()
    assert cap.lines == 7
    assert seen == ["CasADi - WARNING: qrqp failed", "second line"]  # max_distinct = 2
    assert cap.distinct == {"CasADi - WARNING: qrqp failed": 3, "second line": 3}
    assert capfd.readouterr().err == ""  # nothing reached the screen
    os.write(2, b"after\n")
    assert capfd.readouterr().err == "after\n"  # fd 2 restored
