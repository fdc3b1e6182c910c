"""Property vocabularies: the answer phrases of VTV-150K and PhysiCLeAR, kept verbatim.

Ranks are 0/1/2 (low → high); the phrase lists are ordered the same way. Keeping the datasets'
own phrases is what makes our numbers comparable with the papers' tables.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Attribute:
    name: str
    levels: tuple[str, str, str]
    """Answer phrase per rank (0, 1, 2)."""
    more: str
    """Comparative for 'more of this attribute' (SFD/SOI wording), e.g. 'harder'."""
    less: str
    most: str
    least: str

    @property
    def choices(self) -> str:
        """``"soft", "moderately hard" or "hard"``: the level phrases as a single-clip question lists them."""
        quoted = [f'"{phrase}"' for phrase in self.levels]
        return f"{', '.join(quoted[:-1])} or {quoted[-1]}"

    def phrase(self, level: int) -> str:
        if level not in (0, 1, 2):
            raise ValueError(f"{self.name}: level must be 0, 1 or 2, got {level!r}")
        return self.levels[level]


VTV150K: dict[str, Attribute] = {
    "hardness": Attribute("hardness", ("highly deformable", "moderately deformable", "extremely hard"),
                          "harder", "softer", "hardest", "softest"),
    "protrusion": Attribute("protrusion", ("no protrusion", "moderate protrusion", "strong protrusion"),
                            "more protruding", "less protruding", "most protruding", "least protruding"),
    "elasticity": Attribute("elasticity", ("no elasticity", "moderate elasticity", "strong elasticity"),
                            "more elastic", "less elastic", "most elastic", "least elastic"),
    # VTV-150K phrases friction as rough/smooth when objects are compared.
    "friction": Attribute("friction", ("slight friction", "moderate friction", "strong friction"),
                          "rougher", "smoother", "roughest", "smoothest"),
}

PHYSICLEAR: dict[str, Attribute] = {
    "hardness": Attribute("hardness", ("soft", "moderately hard", "hard"), "harder", "softer", "hardest", "softest"),
    "roughness": Attribute("roughness", ("smooth", "slightly rough", "rough"), "rougher", "smoother", "roughest",
                           "smoothest"),
    "bumpiness": Attribute("bumpiness", ("no bumps", "small bumps", "big bumps"), "bumpier", "less bumpy",
                           "bumpiest", "least bumpy"),
}

VOCABULARIES: dict[str, dict[str, Attribute]] = {"vtv150k": VTV150K, "physiclear": PHYSICLEAR}


def get_vocabulary(name: str) -> dict[str, Attribute]:
    try:
        return VOCABULARIES[name]
    except KeyError:
        raise ValueError(f"unknown vocabulary {name!r}; known: {', '.join(VOCABULARIES)}") from None
