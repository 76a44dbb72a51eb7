"""Every command's --help is plain text: no Sphinx markup from the docstrings it is made of."""
import re

import pytest

from skfem_sheet.cli import COMMAND_NAMES, build_parser

#: What Sphinx or reST would render and a terminal shows as it is.
MARKUP = re.compile(r":(func|class|mod|meth|data|attr|ref|doc):|``|^\s*\.\. \w+::", re.M)


def _helps():
    parser = build_parser()
    yield "skfem-sheet", parser.format_help()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    for name, p in sub.choices.items():
        yield name, p.format_help()


@pytest.mark.parametrize("name, text", list(_helps()), ids=lambda x: x if isinstance(x, str)
                         and len(x) < 30 else "")
def test_help_has_no_sphinx_markup(name, text):
    found = [m.group(0) for m in MARKUP.finditer(text)]
    assert not found, f"{name} --help shows markup {found}:\n{text}"


def test_every_command_has_a_help():
    names = [n for n, _ in _helps()]
    assert len(names) == len(COMMAND_NAMES) + 1
