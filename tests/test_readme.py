"""The README's quickstart runs end to end as written."""

import re
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


def test_quickstart_runs(capsys):
    code = re.search(r"```python\n(.*?)```", README.read_text(), re.S).group(1)
    ns = {}
    exec(compile(code, str(README), "exec"), ns)  # our own documentation, not user input
    sol = ns["sol"]
    assert sol.ok and sol.u[0].shape == (17 * 9, 2) and "equilibrium" in capsys.readouterr().out
