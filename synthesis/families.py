"""Seed 001's Table 3 as data: dyad families, the binary links they are built from, N and
N_max, and whether linkwright implements the family."""
from __future__ import annotations

import pandas as pd

__all__ = ["families", "JOINT_LETTERS"]

#: seed 001's joint letters (Cyrillic) → linkwright kinds (С₂ is a spherical pair with a pin: a Hooke joint)
JOINT_LETTERS = {"В": "R", "П": "P", "Ц": "C", "С": "S", "Г": "H", "С₂": "U"}

# (families of the row, binary links of the row, N, N_max) in seed 001's own letters
_TABLE3 = [
    ("ВВВ, (ВГГ), (ВГ'В)", "ВВ, ВВ, (ГГ, ВГ), (ГВ, ВВ)", 4, 5),
    ("ВВГ, (ГВГ), (ГВВ)", "ВГ, ВГ, (ГГ, ВГ), (ГВ, ВВ)", 4, 5),
    ("ВПВ, (ВВП), (ВПГ), (ВГП)", "ПВ, ВВ, (ВП, ВП), (ПГ, ВГ), (ГП, ВП)", 3, 4),
    ("ПВВ, (ПВГ), (ГВП)", "ПВ, ВВ, (ВГ, ВГ), (ГП, ВП)", 3, 4),
    ("ВЦЦ, (ВСГ), (ЦВЦ), (СВГ)", "ЦЦ, ВЦ, (СГ, ВГ), (ЦЦ, ВЦ), (СГ, ВГ)", 6, 13),
    ("ВВЦ, (ВЦВ), (ВС₂Г)", "ВЦ, ВЦ, (ЦВ, ВВ), (С₂Г, ВГ)", 4, 7),
    ("ЦВВ, (С₂ВГ)", "ЦВ, ВВ, (С₂Г, ВГ)", 4, 7),
    ("ВПЦ, (ВЦП), (ПВП), (ЦВП)", "ПЦ, ВЦ, (ЦП, ВП), (ПЦ, ВЦ), (ЦП, ВП)", 3, 6),
    ("ВСВ, (ВС₂Ц), (СВВ), (С₂ВЦ)", "СВ, ВВ, (С₂Ц, ВЦ), (СВ, ВВ), (С₂Ц, ВЦ)", 5, 12),
    ("ВСП, (СВП)", "СП, ВП, (СП, ВП)", 4, 10),
    ("ВС₂В, (С₂ВВ)", "С₂В, ВВ, (С₂В, ВВ)", 4, 6),
    ("ВС₂П, (С₂ВП)", "С₂П, ВП, (С₂П, ВП)", 3, 5),
    ("ВГЦ, (ВЦГ), (ГВЦ), (ЦВГ)", "ГЦ, ВЦ, (ЦГ, ВГ), (ГЦ, ВЦ), (ЦГ, ВГ)", 5, 7),
    ("ВВС", "ВС, ВС", 6, 12),
    # the scan prints "ВВС, (ПВС)": a misprint (that row duplicates row 14 and its binary
    # links are ПС and ВС): the families are ВПС and ПВС (RPS, PRS)
    ("ВПС, (ПВС)", "ПС, ВС или ВС, ПС, (ВС, ПС или ПС, ВС)", 5, 10),
    ("ВГС, (ГВС)", "ГС, ВС, (ГС, ВС)", 7, 13),
    ("ПГС, (ГПС)", "ГС, ПС, (ГС, ПС)", 6, 11),
    ("ЦПЦ, (ПЦЦ)", "ПЦ, ЦЦ (ПЦ, ЦЦ)", 4, 11),
    ("ЦВЦ, (ВЦЦ)", "ВЦ, ЦЦ, (ВЦ, ЦЦ)", 5, 13),
    ("ЦГЦ, (ГЦЦ)", "ГЦ, ЦЦ (ГЦ, ЦЦ)", 6, 14),
]

_IMPLEMENTED = {"RRR", "RRS", "PRS"}

#: (row, family) → how the scan's text was read
_NOTES = {(15, "RPS"): "printed ВВС in the scan (misprint: duplicates row 14); read as ВПС"}


def _latin(word: str) -> str:
    out, i = "", 0
    while i < len(word):
        if word[i:i + 2] == "С₂":
            out += "U"
            i += 2
        elif word[i] in JOINT_LETTERS:
            out += JOINT_LETTERS[word[i]]
            i += 1
        elif word[i] == "'":
            out += "'"
            i += 1
        else:
            i += 1
    return out


def families() -> pd.DataFrame:
    """Seed 001's Table 3, one row per family.

    Columns: ``family`` (joint kinds from ground to body, Latin letters:
    R, P, C, S, H, U for С₂), ``seed`` (the seed's own letters), ``row`` (the
    table row), ``binary_links`` (the binary links synthesised, seed letters),
    ``N`` (positions the method uses), ``N_max`` (positions the chain could
    reach at most), ``implemented`` (whether :func:`enumerate_dyads` has it).
    Row 15 is printed ``ВВС, (ПВС)`` in the scan; it is read as ``ВПС, (ПВС)`` (RPS, PRS:
    its binary links are ПС and ВС, and ВВС is row 14), column ``note`` says so.
    """
    rows = []
    for r, (fams, links, n, nmax) in enumerate(_TABLE3, start=1):
        for word in fams.split(","):
            w = word.strip().strip("()")
            lat = _latin(w)
            rows.append({"family": lat, "seed": w, "row": r, "binary_links": links, "N": n,
                         "N_max": nmax, "implemented": lat in _IMPLEMENTED,
                         "note": _NOTES.get((r, lat), "")})
    return pd.DataFrame(rows)
