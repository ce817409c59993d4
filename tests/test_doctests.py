"""The examples in the docstrings of the public modules run and give what they show."""

import doctest
import importlib
import pkgutil

import pytest

import retrofit

MODULES = sorted(m.name for m in pkgutil.walk_packages(retrofit.__path__, "retrofit.")
                 if not m.name.startswith("retrofit.cli"))


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0, f"{result.failed} docstring example(s) of {name} failed"
