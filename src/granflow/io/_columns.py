"""THE table of vendor labels (English, French, German, Spanish, Italian) and the unit
conversions to SI.

Every reader maps column names and header keywords through this one module, so a new
language or a new vendor spelling is one more string in a tuple below. The French spellings
include those of real RheoCompass exports ("Interval données:", "Intervalle Temps",
"Gradient de Cisaillement", "Etat"); the Spanish and Italian ones are the software's terms
as translated, not yet checked against a real export. Where a header's names are unknown,
:func:`quantity_from_unit` finds the column's role from its unit. Matching ignores
case, accents and surrounding spaces ("Angle de deflexion" finds "Angle de Déflexion").

Units are converted in one place, :func:`si_factor`, with pint (via :mod:`granflow.model.units`):
an unknown unit is an error naming it, never a guess.
"""

import math
import re
import unicodedata

from granflow.errors import InvalidParameterError
from granflow.model import units
from granflow.model.units import to_si

__all__ = [
    "KEYWORDS",
    "LANGUAGES",
    "MAPPED_ONLY",
    "METADATA",
    "OWN_QUANTITIES",
    "QUANTITIES",
    "SI_UNITS",
    "TEXT_QUANTITIES",
    "column_label",
    "control_from_text",
    "known_label",
    "known_unit",
    "label",
    "match_keyword",
    "match_metadata",
    "match_quantity",
    "normalize",
    "own_column",
    "quantity_from_unit",
    "refine",
    "si_factor",
]

LANGUAGES = ("en", "fr", "de", "es", "it")

#: Column labels per quantity and language, in order of preference (the first one of each
#: language is what the writer prints). "vendor" holds spellings of other software (TRIOS).
QUANTITIES = {
    "point": {
        "en": ("Point No.", "Meas. Pts.", "Point"),
        "fr": ("N° de point", "Pts. de mes.", "Point"),
        "de": ("Punkt Nr.", "Messpkt.", "Messpunkt"),
        "es": ("N.º de punto", "Punto"),
        "it": ("N. punto", "Punto"),
    },
    "interval_time": {
        "en": ("Interval Time",),
        "fr": ("Temps d'intervalle", "Intervalle Temps"),
        "de": ("Intervallzeit",),
        "es": ("Tiempo de intervalo",),
        "it": ("Tempo intervallo",),
        "vendor": ("Step time",),
    },
    "time": {
        "en": ("Time",),
        "fr": ("Temps",),
        "de": ("Zeit",),
        "es": ("Tiempo",),
        "it": ("Tempo",),
    },
    "torque": {
        "en": ("Torque",),
        "fr": ("Couple",),
        "de": ("Drehmoment",),
        "es": ("Par", "Par de torsión"),
        "it": ("Coppia",),
    },
    "speed": {
        "en": ("Rotational Speed", "Speed"),
        "fr": ("Vitesse de Rotation", "Vitesse"),
        "de": ("Drehzahl",),
        "es": ("Velocidad de rotación", "Velocidad"),
        "it": ("Velocità di rotazione", "Velocità"),
        "vendor": ("Velocity", "Angular velocity"),
    },
    "angle": {
        "en": ("Deflection Angle",),
        "fr": ("Angle de Déflexion",),
        "de": ("Auslenkwinkel",),
        "es": ("Ángulo de deflexión",),
        "it": ("Angolo di deflessione",),
        "vendor": ("Displacement", "Angular displacement"),
    },
    "normal_force": {
        "en": ("Normal Force",),
        "fr": ("Force Normale",),
        "de": ("Normalkraft",),
        "es": ("Fuerza normal",),
        "it": ("Forza normale",),
        "vendor": ("Axial force",),
    },
    "shear_stress": {
        "en": ("Shear Stress",),
        "fr": ("Contrainte de Cisaillement",),
        "de": ("Schubspannung",),
        "es": ("Esfuerzo cortante",),
        "it": ("Sollecitazione di taglio",),
        "vendor": ("Stress",),
    },
    "shear_rate": {
        "en": ("Shear Rate",),
        "fr": ("Vitesse de Cisaillement", "Gradient de Cisaillement"),
        "de": ("Scherrate",),
        "es": ("Velocidad de cizallamiento",),
        "it": ("Velocità di taglio",),
    },
    "strain": {
        "en": ("Shear Strain", "Strain"),
        "fr": ("Déformation de Cisaillement", "Déformation"),
        "de": ("Scherdeformation", "Deformation"),
        "es": ("Deformación de cizallamiento", "Deformación"),
        "it": ("Deformazione di taglio", "Deformazione"),
    },
    "status": {
        "en": ("Status",),
        "fr": ("Statut", "État"),
        "de": ("Status",),
        "es": ("Estado",),
        "it": ("Stato",),
    },
}

#: granflow's own quantities (its tables, a spreadsheet), beside the instrument quantities
#: above: recognised by these labels with a unit of their dimension ("slip [µm]",
#: "force [mN]", "velocity [m/s]"), by the names granflow writes ("slip_m", "force_N",
#: "velocity_m_s", see :func:`own_column`), or through a column map. "Velocity" is also a
#: vendor label of the rotational speed: its unit decides (:func:`refine`).
OWN_QUANTITIES = {
    "slip": ("Slip",),
    "force": ("Force", "Friction Force"),
    "velocity": ("Sliding Velocity",),
    "control": ("Control",),
}
#: Columns of text, not numbers: an instrument's status, granflow's control mode per row.
TEXT_QUANTITIES = ("status", "control")
#: The names granflow writes, before their unit suffix: name -> quantity.
_OWN_NAMES = {"t": "time", "time": "time", "slip": "slip", "velocity": "velocity", "force": "force"}
_OWN_NAME = re.compile(r"^(?P<name>[A-Za-z]+)_(?P<unit>[A-Za-zµμ0-9]+(?:_[A-Za-zµμ0-9]+)?)$")
#: Kept for a column map's quantities: granflow's own, no vendor label.
MAPPED_ONLY = tuple(OWN_QUANTITIES)

#: The SI unit of each column quantity, from the one unit table
#: (:data:`granflow.model.units.QUANTITIES`); None: a count or text, no unit.
SI_UNITS = {
    name: units.QUANTITIES[name].si
    if name in units.QUANTITIES and name not in TEXT_QUANTITIES
    else None
    for name in (*QUANTITIES, *MAPPED_ONLY)
}

#: Structural keywords of the exports (the label cell that starts a header line).
KEYWORDS = {
    "project": {
        "en": ("Project:",),
        "fr": ("Projet:",),
        "de": ("Projekt:",),
        "es": ("Proyecto:",),
        "it": ("Progetto:",),
    },
    "test": {
        "en": ("Test:",),
        "fr": ("Test:", "Essai:"),
        "de": ("Test:", "Versuch:"),
        "es": ("Ensayo:", "Prueba:", "Test:"),
        "it": ("Test:", "Prova:"),
    },
    "result": {
        "en": ("Result:",),
        "fr": ("Résultat:",),
        "de": ("Ergebnis:",),
        "es": ("Resultado:",),
        "it": ("Risultato:",),
    },
    "interval_points": {
        "en": ("Interval and data points:",),
        "fr": ("Intervalle et points de données:",),
        "de": ("Intervall und Datenpunkte:",),
        "es": ("Intervalo y puntos de datos:",),
        "it": ("Intervallo e punti dati:",),
    },
    "interval_data": {
        "en": ("Interval data:", "Data interval:"),
        "fr": ("Interval données:", "Données d'intervalle:"),
        "de": ("Intervalldaten:",),
        "es": ("Datos de intervalo:",),
        "it": ("Dati intervallo:",),
    },
    "series": {
        "en": ("Data Series Information",),
        "fr": ("Informations sur la série de données",),
        "de": ("Datenreihen-Information",),
        "es": ("Información de la serie de datos",),
        "it": ("Informazioni sulla serie di dati",),
    },
    "interval": {
        "en": ("Interval:",),
        "fr": ("Intervalle:",),
        "de": ("Intervall:",),
        "es": ("Intervalo:",),
        "it": ("Intervallo:",),
    },
    "profile": {
        "en": ("Measuring Profile:",),
        "fr": ("Profil de mesure:",),
        "de": ("Messprofil:",),
        "es": ("Perfil de medición:",),
        "it": ("Profilo di misura:",),
    },
}

#: Metadata keys: label per language, and the SI unit of the value (None: text).
METADATA = {
    "sample": (
        {"en": "Sample", "fr": "Échantillon", "de": "Probe", "es": "Muestra", "it": "Campione"},
        None,
    ),
    "preparation": (
        {
            "en": "Preparation",
            "fr": "Préparation",
            "de": "Präparation",
            "es": "Preparación",
            "it": "Preparazione",
        },
        None,
    ),
    "normal_load": (
        {
            "en": "Normal Load",
            "fr": "Charge Normale",
            "de": "Normallast",
            "es": "Carga Normal",
            "it": "Carico Normale",
        },
        units.si_unit("normal_load"),
    ),
    "rest_time": (
        {
            "en": "Rest Time",
            "fr": "Temps de Repos",
            "de": "Ruhezeit",
            "es": "Tiempo de Reposo",
            "it": "Tempo di Riposo",
        },
        units.si_unit("rest_time"),
    ),
    "velocity": (
        {
            "en": "Nominal Velocity",
            "fr": "Vitesse Nominale",
            "de": "Nenngeschwindigkeit",
            "es": "Velocidad Nominal",
            "it": "Velocità Nominale",
        },
        units.si_unit("velocity"),
    ),
    "control": (
        {
            "en": "Control Mode",
            "fr": "Mode de Contrôle",
            "de": "Regelungsart",
            "es": "Modo de Control",
            "it": "Modalità di Controllo",
        },
        None,
    ),
}

#: Words that name the control mode, in any language (profile lines and "Control Mode").
_CONTROL_WORDS = {
    "rate": (
        "rate",
        "speed",
        "strain",
        "shear rate",
        "deflection",
        "velocity",
        "vitesse",
        "deformation",
        "geschwindigkeit",
        "drehzahl",
        "scherrate",
        "velocidad",
        "velocita",
        "deformacion",
        "deformazione",
    ),
    "stress": (
        "stress",
        "torque",
        "contrainte",
        "couple",
        "spannung",
        "schubspannung",
        "drehmoment",
        "esfuerzo",
        "par",
        "sollecitazione",
        "coppia",
    ),
}

#: Control-mode words the writer prints, per language.
CONTROL_LABELS = {
    "en": {"rate": "Rate", "stress": "Stress"},
    "fr": {"rate": "Vitesse", "stress": "Contrainte"},
    "de": {"rate": "Geschwindigkeit", "stress": "Spannung"},
    "es": {"rate": "Velocidad", "stress": "Esfuerzo"},
    "it": {"rate": "Velocità", "stress": "Sollecitazione"},
}


def normalize(text):
    """Lower case, accents removed, inner spaces collapsed: the key labels are compared by."""
    decomposed = unicodedata.normalize("NFKD", str(text))
    stripped = "".join(char for char in decomposed if not unicodedata.combining(char))
    return " ".join(stripped.lower().replace("’", "'").split())


def _index(table):
    index = {}
    for key, spellings in table.items():
        for group in spellings.values():
            for rank, spelling in enumerate(group if isinstance(group, tuple) else (group,)):
                index.setdefault(normalize(spelling), (key, rank))
    return index


_QUANTITY_INDEX = _index(
    {**QUANTITIES, **{key: {"granflow": labels} for key, labels in OWN_QUANTITIES.items()}}
)
_KEYWORD_INDEX = _index(KEYWORDS)
_METADATA_INDEX = {
    normalize(spelling): key
    for key, (labels, _) in METADATA.items()
    for spelling in labels.values()
}


def match_quantity(name):
    """(quantity, rank) for a column label, or (None, None) when it is not in the table."""
    return _QUANTITY_INDEX.get(normalize(name), (None, None))


def own_column(name):
    """(quantity, unit) of a column named as granflow writes it ("t_s", "slip_m",
    "velocity_m_s", "force_N"; also "force_mN", "slip_um"), else None.

    Examples
    --------
    >>> own_column("velocity_m_s"), own_column("force_mN"), own_column("Step_time")
    (('velocity', 'm/s'), ('force', 'mN'), None)
    """
    match = _OWN_NAME.match(name.strip())
    if match is None or match["name"].lower() not in _OWN_NAMES:
        return None
    return _OWN_NAMES[match["name"].lower()], match["unit"].replace("_", "/")


def known_label(name):
    """Whether a column name is granflow's vocabulary: a label of the table or a name granflow
    writes. Error messages quote only such names (and units pint knows); any other text of a
    file is named by its line and column, never copied (:func:`column_label`)."""
    return match_quantity(name)[0] is not None or own_column(name) is not None


def column_label(position, name):
    """How an error names column ``position`` (0-based) of a header: "column 3 ('Torque')"
    for a known label, "column 3" for any other text (which is not copied)."""
    if known_label(name):
        return f"column {position + 1} ({name.strip()!r})"
    return f"column {position + 1}"


def known_unit(unit):
    """Whether pint knows ``unit`` (after the instrument spellings are rewritten)."""
    from granflow.model.units import unit_registry

    text = _pint_unit("torque", unit).replace("μ", "u").replace("µ", "u")
    try:
        unit_registry().Unit(text)
    except Exception:  # pint raises several unrelated types for bad units
        return False
    return True


def refine(quantity, unit):
    """The quantity a recognised label measures, given its unit: "Velocity" in m/s (or µm/s)
    is the sliding velocity, in rad/s or 1/min the rotational speed."""
    if quantity == "speed" and unit.strip():
        try:
            si_factor("velocity", unit)
        except InvalidParameterError:
            return quantity
        return "velocity"
    return quantity


def match_keyword(cell):
    """The structural keyword a header cell is ("test", "interval_data", ...), or None."""
    hit = _KEYWORD_INDEX.get(normalize(cell))
    return None if hit is None else hit[0]


def match_metadata(label):
    """The metadata key a label names ("normal_load", ...), or None."""
    return _METADATA_INDEX.get(normalize(label.rstrip(":").split("[")[0]))


def label(quantity, language):
    """The label the writer prints for ``quantity`` in ``language``."""
    return QUANTITIES[quantity][language][0]


def keyword(name, language):
    """The structural keyword the writer prints in ``language``."""
    return KEYWORDS[name][language][0]


def control_from_text(text):
    """ "rate" or "stress" when ``text`` names a control mode or profile quantity, else None."""
    words = normalize(text)
    found = {
        mode
        for mode, names in _CONTROL_WORDS.items()
        if any(re.search(rf"\b{re.escape(name)}\b", words) for name in names)
    }
    return found.pop() if len(found) == 1 else None


#: What a unit says a column measures when its name is unknown (structure, not keywords).
_UNIT_ROLES = (
    ("torque", re.compile(r"^[µμunmkc]?N\s*[·⋅.*\s]?\s*m$")),
    ("angle", re.compile(r"^(?:[mµμu]?rad|°|deg)$")),
    ("speed", re.compile(r"^(?:1/min|min⁻¹|rpm|rad/s)$")),
    ("time", re.compile(r"^(?:s|min|h|ms)$")),
    ("normal_force", re.compile(r"^[µμumk]?N$")),
)


def quantity_from_unit(unit):
    """The quantity a column measures judged by its unit alone: torque from N·m, angle from
    rad or °, speed from 1/min or rad/s, time from s or min, normal force from N; else None
    (1/s is a shear rate as much as a speed: not decided)."""
    text = unit.strip().strip("[]").strip()
    return next((quantity for quantity, pattern in _UNIT_ROLES if pattern.match(text)), None)


_TORQUE_PRODUCT = re.compile(r"N\s*[·⋅.*\s]?\s*m$")


def _pint_unit(quantity, unit):
    """Rewrite instrument spellings into pint's: µNm, µN.m, N m -> µN*m; ° -> deg."""
    text = unit.strip()
    if quantity == "torque":
        text = _TORQUE_PRODUCT.sub("N*m", text)
    text = text.replace("°", "deg").replace("%", "percent").replace("min⁻¹", "1/min")
    return text.replace("s⁻¹", "1/s")


def si_factor(quantity, unit):
    """The factor from ``unit`` to the SI unit of ``quantity`` (``SI_UNITS``).

    Rotational speeds go to rev/s: "1/min" and "1/s" (and "rpm") count revolutions, as
    rheometers print them; "rad/s" and "deg/s" are angular velocities.

    Raises
    ------
    InvalidParameterError
        The unit is unknown to pint or has the wrong dimension for ``quantity``.
    """
    target = SI_UNITS[quantity]
    if target is None:
        return 1.0
    text = _pint_unit(quantity, unit)
    if text in ("", "1") and target == "1":
        return 1.0
    if text == "":
        raise InvalidParameterError(f"{quantity}: no unit given, expected one like {target!r}")
    from granflow.model.units import unit_registry

    registry = unit_registry()
    try:
        if quantity == "speed":
            angular = any(word in text for word in ("rad", "deg"))
            value = registry.Quantity(1.0, text.replace("rpm", "1/min"))
            factor = value.to("rad/s").magnitude / (2 * math.pi) if angular else None
            if factor is None:
                factor = value.to("1/s").magnitude
            return float(factor)
        value = to_si(1.0, text, quantity)
        expected = registry.Quantity(1.0, target.replace(" ", "*"))
        measured = registry.Quantity(1.0, text.replace("μ", "u").replace("µ", "u"))
        if measured.dimensionality != expected.dimensionality:
            raise InvalidParameterError(f"unit {unit!r} is not a unit of {quantity} ({target})")
        return float(value)
    except InvalidParameterError as exc:
        if "unit" in str(exc) and repr(unit) in str(exc):
            raise
        raise _unit_error(quantity, unit, target) from None
    except Exception:  # pint raises several unrelated types for bad units
        raise _unit_error(quantity, unit, target) from None


def _unit_error(quantity, unit, target):
    """The error of a unit that does not convert: it quotes a unit pint knows ('mm' for a
    torque), never text that is no unit (a header that is not one is not copied)."""
    if known_unit(unit):
        what = f"unit {unit!r} is not a unit of {quantity}"
    else:
        what = f"the unit is not one granflow knows for {quantity}"
    return InvalidParameterError(f"{what} (expected one like {target!r})")
