"""MkDocs hooks (mkdocs.yml ``hooks``): the site's home page is README.md and its changelog CHANGELOG.md.

Both files live at the top of the repository, where their links into the docs read ``docs/PAGE.md``; on the
site those pages are at ``PAGE.md``, so the prefix is dropped, and README's link to CHANGELOG.md leads to the
changelog page. ``docs/index.md`` and ``docs/changelog.md`` hold only a marker line naming the file whose text
replaces them.
"""

from __future__ import annotations

import re
from pathlib import Path

_MARKER = re.compile(r"<!-- include: ([\w.-]+) -->")


def on_page_markdown(markdown: str, page, config, files) -> str:
    """A page that is only an include marker becomes that top-level file, its ``docs/`` links made site-relative."""
    m = _MARKER.fullmatch(markdown.strip())
    if m is None:
        return markdown
    path = Path(config["config_file_path"]).parent / m[1]
    text = path.read_text(encoding="utf-8")
    text = re.sub(r"\]\(docs/", "](", text)
    return text.replace("](CHANGELOG.md)", "](changelog.md)")
