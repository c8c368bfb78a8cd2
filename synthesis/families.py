"""Seed 001's Table 3 as data: dyad families, the binary links they are built from, N and
N_max, and whether linkwright implements the family."""
from __future__ import annotations

import pandas as pd

__all__ = ["families", "family_names", "JOINT_LETTERS"]

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

#: the two binary links printed for each family, row by row, in Latin letters
_LINKS = {
    1: ["RR, RR", "HH, RH", "HR, RR"], 2: ["RH, RH", "HH, RH", "HR, RR"],
    3: ["PR, RR", "RP, RP", "PH, RH", "HP, RP"], 4: ["PR, RR", "RH, RH", "HP, RP"],
    5: ["CC, RC", "SH, RH", "CC, RC", "SH, RH"], 6: ["RC, RC", "CR, RR", "UH, RH"],
    7: ["CR, RR", "UH, RH"], 8: ["PC, RC", "CP, RP", "PC, RC", "CP, RP"],
    9: ["SR, RR", "UC, RC", "SR, RR", "UC, RC"], 10: ["SP, RP", "SP, RP"],
    11: ["UR, RR", "UR, RR"], 12: ["UP, RP", "UP, RP"],
    13: ["HC, RC", "CH, RH", "HC, RC", "CH, RH"], 14: ["RS, RS"],
    15: ["PS, RS", "RS, PS"], 16: ["HS, RS", "HS, RS"], 17: ["HS, PS", "HS, PS"],
    18: ["PC, CC", "PC, CC"], 19: ["RC, CC", "RC, CC"], 20: ["HC, CC", "HC, CC"]}

#: (row, seed word) → the family it is read as, where the scan is misprinted
_READ_AS = {(8, "ПВП"): "PRC"}

#: (row, family) → how the scan's text was read, and what the construction reaches
_NOTES = {
    (15, "RPS"): "printed ВВС in the scan (misprint: duplicates row 14); read as ВПС",
    (8, "PRC"): "printed ПВП in the scan, whose links ПЦ, ВЦ have no P–P pair: read as ПВЦ "
                "(arrangement b of ВПЦ, as ЦВП is of ВЦП)",
    (4, "PRH"): "links printed ВГ, ВГ; the construction is PH (joints 1, 3) with R carrying H",
    (1, "RHR"): "printed ВГ'В (the prime marks nothing kinematic here)",
}
for _r, _f in ((13, "RHC"), (13, "RCH"), (13, "HRC"), (13, "CRH")):
    _NOTES[(_r, _f)] = ("implemented with the pitch given: main HC/CH link through 3 positions "
                        "(fixed direction free) + R transition: N = 4; the printed N = 5 takes "
                        "the pitch as a design variable (HC/CH through 4 positions), not "
                        "implemented")
for _f in ("CHC", "HCC"):
    _NOTES[(20, _f)] = ("implemented with the pitch given: main HC through 3 positions + C "
                        "transition through 2: N = 5; the printed N = 6 takes the pitch as a "
                        "design variable (HC through 4), not implemented")
for _f in ("RCC", "CRC"):
    _NOTES[(5, _f)] = "also in row 19 (N = 5, main RC + C transition); both are implemented"
    _NOTES[(19, _f)] = "also in row 5 (N = 6, main CC through 5 + R transition); both implemented"


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
            i += 1                       # ВГ'В: the prime marks nothing kinematic (note)
        else:
            i += 1
    return out


def family_names() -> list[str]:
    """The families of Table 3 (Latin letters, ground joint first), in table order, each
    once (misprints read as :func:`families` notes)."""
    out = []
    for r, (fams, *_rest) in enumerate(_TABLE3, start=1):
        for word in fams.split(","):
            w = word.strip().strip("()")
            lat = _READ_AS.get((r, w), _latin(w))
            if lat not in out:
                out.append(lat)
    return out


def families() -> pd.DataFrame:
    """Kharatyan's Table 3 (1981), one row per family and table row (53 rows, 51 distinct
    families: RCC and CRC appear in rows 5 and 19 with different constructions).

    Columns: ``family`` (joint kinds from ground to body, Latin letters:
    R, P, C, S, H, U for С₂), ``seed`` (the paper's own letters), ``row`` (the
    table row), ``binary_links`` (the row's binary links as printed, Cyrillic),
    ``links`` (this family's two binary links as printed, Latin), ``N`` (positions the
    method uses, as printed), ``N_max`` (positions the chain could reach at most, as
    printed), ``implemented`` (whether :func:`enumerate_dyads` builds it),
    ``arrangement`` (the implemented arrangements, ``a``: main link joints 2–3 and joint
    1 the transition joint, ``b``: main link joints 1 and 3, joint 2 the transition),
    ``main_link`` and ``transition`` (per arrangement; the transition as "XY": joint X
    carrying joint 3 of kind Y), ``N_implemented`` (the numbers of positions the
    implemented constructions take), ``note`` (misprints, and where the implemented N
    differs from the printed one).
    Row 15 is printed ``ВВС, (ПВС)`` in the scan; it is read as ``ВПС, (ПВС)`` (RPS, PRS:
    its binary links are ПС and ВС, and ВВС is row 14), column ``note`` says so.
    """
    from .decompose import arrangements
    from .dyads import _family_module, implemented_families
    impl = implemented_families()
    rows = []
    for r, (fams, links, n, nmax) in enumerate(_TABLE3, start=1):
        for i, word in enumerate(fams.split(",")):
            w = word.strip().strip("()")
            lat = _READ_AS.get((r, w), _latin(w))
            how = impl.get(lat)
            arr = [a for a in arrangements(lat)] if how is not None and \
                how[0] == "direct" else []
            mod = _family_module(lat) if how is not None else None
            if mod is not None:
                arr = mod.ARRANGEMENTS(lat)
            elif lat == "RRR":
                arr = [("a", "RR", "R", 3, 1), ("b", "RR", "R", 3, 1)]
            if any(a[3] + a[4] == n for a in arr):
                arr = [a for a in arr if a[3] + a[4] == n]
            note = _NOTES.get((r, lat), "")
            n_impl = tuple(how[1]) if how is not None else ()
            if mod is not None and mod.FAMILIES[lat][2]:
                note = mod.FAMILIES[lat][2]      # the implementing module's own note
            elif how is not None and n not in n_impl and (r, lat) not in _NOTES:
                note = (f"the implemented construction takes N = "
                        f"{', '.join(map(str, n_impl))}, the paper prints {n}")
            rows.append({"family": lat, "seed": w, "row": r, "binary_links": links,
                         "links": _LINKS[r][i], "N": n, "N_max": nmax,
                         "implemented": how is not None,
                         "arrangement": ", ".join(a[0] for a in arr),
                         "main_link": ", ".join(a[1] for a in arr),
                         "transition": ", ".join(a[2] + lat[2] for a in arr),
                         "N_implemented": n_impl, "note": note})
    return pd.DataFrame(rows)
