"""The "did you mean" of an unknown name: the one known name a typo is closest to, or nothing.

A suggestion is made only when it is unambiguous and close: at most one edit (a letter added, dropped,
changed, or two neighbours swapped) for names of up to five letters, two for longer ones, case ignored. So
``rnage`` gets ``range`` and ``los`` gets ``loss``, while ``delay`` gets nothing (two edits from ``delta``,
which is not what a user who typed it meant).
"""

from __future__ import annotations

from collections.abc import Iterable


def edits(a: str, b: str) -> int:
    """Edits between ``a`` and ``b``: insertions, deletions, substitutions and swaps of neighbours."""
    rows = [list(range(len(b) + 1))]
    for i in range(1, len(a) + 1):
        row = [i] + [0] * len(b)
        for j in range(1, len(b) + 1):
            row[j] = min(rows[-1][j] + 1, row[j - 1] + 1, rows[-1][j - 1] + (a[i - 1] != b[j - 1]))
            if i > 1 and j > 1 and a[i - 1] == b[j - 2] and a[i - 2] == b[j - 1]:
                row[j] = min(row[j], rows[-2][j - 2] + 1)
        rows.append(row)
    return rows[-1][-1]


def did_you_mean(word: str, known: Iterable[str]) -> str:
    """``"; did you mean 'range'?"`` for the one known name close to ``word`` (see the module), else ``""``."""
    limit = 1 if len(word) <= 5 else 2
    scored = sorted((edits(word.lower(), k.lower()), k) for k in known)
    close = [k for d, k in scored if d <= limit and d == scored[0][0]]
    return f"; did you mean {close[0]!r}?" if len(close) == 1 else ""
