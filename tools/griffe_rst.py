"""A griffe extension for the documentation's API reference: the package's docstrings are
numpydoc with reStructuredText inline markup; mkdocstrings renders Markdown. Roles
(``:class:`~a.b.C```) become code spans, and a "Class attributes" section is read as numpydoc's
"Attributes" section.

Named in ``mkdocs.yml`` under the Python handler's ``extensions``.
"""

from __future__ import annotations

import re
from typing import Any

import griffe

from odorloc.core.describe import markdown


class RstToMarkdown(griffe.Extension):
    """Rewrite each docstring's inline markup for Markdown when its object is loaded."""

    def on_instance(self, *, node: Any, obj: griffe.Object, agent: Any, **kwargs: Any) -> None:
        if obj.docstring is None:
            return
        text = markdown(obj.docstring.value)
        text = re.sub(
            r"^(\s*)Class attributes\n(\s*)-{3,}$", r"\1Attributes\n\2----------", text, flags=re.M
        )
        obj.docstring.value = text
