"""MkDocs hook: Sphinx cross-reference roles in the docstrings shown as plain code.

The docstrings of stewart_jax name other objects the Sphinx way, ``:func:`diagnose```,
``:class:`~stewart_jax.mechanism.AbstractMechanism```. mkdocstrings renders docstrings as
Markdown, where such a role comes out as the literal text ``:func:`` before the code span. This
hook removes the role and, as Sphinx does for a leading ``~``, keeps only the last component of
the name. It changes the rendered HTML only, never a docstring.
"""

from __future__ import annotations

import re

_ROLE = re.compile(r":(?:py:)?(?:func|class|mod|meth|attr|data|obj|exc|const):(<code>)~?([^<]*?)(</code>)")


def _strip(match: re.Match[str]) -> str:
    name = match.group(2)
    if match.group(0)[match.start(2) - match.start(0) - 1] == "~":
        name = name.rsplit(".", 1)[-1]
    return f"{match.group(1)}{name}{match.group(3)}"


def on_page_content(html: str, page, config, files) -> str:
    return _ROLE.sub(_strip, html)
