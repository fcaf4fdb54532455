"""Every example in a docstring runs and prints what it says (numpydoc ``Examples`` sections)."""

import doctest
import importlib
import pkgutil

import pytest

import hybridedit

MODULES = sorted(info.name for info in pkgutil.walk_packages(hybridedit.__path__, prefix="hybridedit.")
                 if not info.name.endswith("__main__"))


def test_the_package_has_examples_to_run():
    finder = doctest.DocTestFinder()
    n = sum(len(t.examples) for name in MODULES for t in finder.find(importlib.import_module(name)))
    assert n >= 30


@pytest.mark.parametrize("name", MODULES)
def test_examples(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE, report=True)
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples failed in {name} (see above)"
