"""The README's Python examples on the simulator run as written (with the repository's EDS as
their `device.eds` and `servo.eds`)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from conftest import EDS, EDS_DIR

README = Path(__file__).resolve().parents[3] / "README.md"


def examples() -> list[str]:
    """The `python` blocks of the README that use the simulator."""
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), re.S)
    return [b for b in blocks if "canola.MemoryBus()" in b]


def test_the_readme_has_the_examples() -> None:
    assert len(examples()) >= 3


@pytest.mark.parametrize("n", range(3))
def test_readme_example_runs(n: int) -> None:
    code = examples()[n].replace('"device.eds"', repr(str(EDS)))
    code = code.replace('"servo.eds"', repr(str(EDS_DIR / "cia402-servo.eds")))
    exec(compile(code, f"README.md example {n + 1}", "exec"), {})
