"""The documentation is checked: every docstring example runs (doctest), and mypy accepts the
package, this test suite and the READMEs' Python examples."""

import doctest
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import spincal
import spincal._frames
import spincal._params
import spincal._results

PACKAGE = Path(spincal.__file__).resolve().parent
TESTS = Path(__file__).resolve().parent
CRATE = TESTS.parents[1]
ROOT = CRATE.parents[1]
READMES = [ROOT / "README.md", CRATE / "README.md"]


@pytest.mark.parametrize("module", [spincal, spincal._results, spincal._params, spincal._frames], ids=lambda m: m.__name__)
def test_docstring_examples_run(module, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    globs = {"spincal": spincal, "np": np, **{n: getattr(spincal._results, n) for n in ("Result", "Parameter", "Parameters")}}
    finder = doctest.DocTestFinder(exclude_empty=True)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    examples = 0
    report: list = []
    for test in finder.find(module, module.__name__, globs=globs):
        runner.run(test, out=report.append)
        examples += sum(1 for e in test.examples if not e.options.get(doctest.SKIP))
    failed, attempted = runner.failures, runner.tries
    assert failed == 0, f"{failed} of {attempted} docstring examples failed:\n" + "".join(report)
    # Each module documents something that runs (not only skipped examples).
    assert examples > 0


def _python_blocks(path):
    text = path.read_text()
    return re.findall(r"```python\n(.*?)```", text, flags=re.S)


def test_readme_examples_exist():
    for readme in READMES:
        assert _python_blocks(readme), f"{readme} has no ```python example"


def test_mypy_accepts_the_package_the_tests_and_the_readme_examples(tmp_path):
    pytest.importorskip("mypy")
    examples = []
    for readme in READMES:
        for k, block in enumerate(_python_blocks(readme)):
            path = tmp_path / f"readme_{readme.parent.name}_{k}.py"
            path.write_text(block)
            examples.append(str(path))
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "mypy",
            "--config-file",
            str(CRATE / "pyproject.toml"),
            "--cache-dir",
            str(tmp_path / "mypy-cache"),
            # The package under test (this build's), the tests, the READMEs' examples.
            PACKAGE.name,
            str(TESTS),
            *examples,
        ],
        cwd=PACKAGE.parent,
        capture_output=True,
        text=True,
        env={**os.environ, "MYPYPATH": str(PACKAGE.parent)},
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert "Success" in done.stdout
