"""The sweep files of the reference-solution generator's tests (tests/test_sweep.py, tests/test_sweep_faults.py):
a sweep over the example scene examples/two_blocks.toml written to a folder. A fixtures module: the test modules
do not import each other.
"""

import json
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def write_sweep(tmp_path, grid, extra="", method="condensed", small=True):
    """A sweep file over the example's scene (meshes halved if ``small``) with this ``[grid]``."""
    text = (EXAMPLES / "two_blocks.toml").read_text()
    if small:
        text = text.replace("nx = 16, ny = 8", "nx = 8, ny = 4").replace("nx = 11, ny = 6", "nx = 6, ny = 3")
    (tmp_path / "scene.toml").write_text(text)
    lines = ['scene = "scene.toml"', f'method = "{method}"', extra, "[grid]"]
    lines += [f'"{k}" = {json.dumps(v)}' for k, v in grid.items()]
    path = tmp_path / "sweep.toml"
    path.write_text("\n".join(lines) + "\n")
    return path
