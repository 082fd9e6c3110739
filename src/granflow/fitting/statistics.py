"""Pieces shared by the fit results' ``to_dict`` and ``report`` (single, joint, creep fits)."""

STATISTICS = ("success", "message", "ndata", "nfree", "chisqr", "redchi", "aic", "bic")


def estimates(result):
    """The parameter estimates of a fit result as plain mappings: params, stderr, ci95, covar."""
    return {
        "params": dict(result.params),
        "stderr": dict(result.stderr),
        "ci95": {name: list(interval) for name, interval in result.ci95.items()},
        "covar": {name: dict(row) for name, row in result.covar.items()},
    }


def statistics(result):
    """Goodness of fit of a result: success, message, counts, chi-square, AIC, BIC and
    whether the noise was known."""
    return {
        **{key: getattr(result, key) for key in STATISTICS},
        "sigma_known": result.sigma_known,
    }


def statistics_lines(result, *, title, extra=()):
    """The lmfit-style header block: ``[[title]]`` then one aligned line per statistic
    (``extra``: (label, text) pairs inserted after the message)."""
    rows = [("success", result.success), ("message", result.message), *extra]
    rows += [
        ("# data points", result.ndata),
        ("# variables", result.nfree),
        ("chi-square", f"{result.chisqr:.6g}"),
        ("reduced chi-square", f"{result.redchi:.6g}"),
        ("Akaike info crit", f"{result.aic:.6g}"),
        ("Bayesian info crit", f"{result.bic:.6g}"),
    ]
    return [f"[[{title}]]", *(f"    {label:<18} = {value}" for label, value in rows)]


def variable_line(name, value, stderr, interval, *, unit="", width=6):
    """One ``[[Variables]]`` line: ``name = value +/- stderr unit  95%: [low, high]``."""
    unit = f" {unit}" if unit else ""
    low, high = interval
    return f"    {name:<{width}} = {value:.8g} +/- {stderr:.4g}{unit}  95%: [{low:.6g}, {high:.6g}]"
