"""Math in the documentation, drawn offline by matplotlib's mathtext: nothing downloaded.

Registers an HTML math renderer for Sphinx (``html_math_renderer = "mathtext_svg"``): every
``:math:`` role and ``.. math::`` block is drawn to SVG by :func:`matplotlib.mathtext.math_to_image`
at build time and embedded in the page as a data URI, its baseline aligned with the text.
No MathJax, no CDN, no LaTeX installation: matplotlib is a dependency of granflow already.
mathtext reads the common subset of TeX (fractions, sub- and superscripts, Greek letters,
``\\ln``, ``\\int``, ``\\mathrm``, ``\\left( \\right)``); a formula it cannot parse is a build
warning (and ``-W`` makes it an error).
"""

import base64
import functools
import html
import io
import re

from docutils import nodes
from sphinx.util import logging

logger = logging.getLogger(__name__)

#: Font size of the formulas [pt], to sit with the theme's body text.
FONT_SIZE = 12.5


@functools.cache
def _svg(latex: str, display: bool) -> tuple[str, float, float, float]:
    """(data URI, width, height, depth) in pt of ``latex`` drawn by mathtext."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import mathtext
    from matplotlib.font_manager import FontProperties

    buffer = io.BytesIO()
    size = FONT_SIZE * (1.15 if display else 1.0)
    with matplotlib.rc_context({"svg.fonttype": "path", "mathtext.fontset": "dejavuserif"}):
        depth = mathtext.math_to_image(
            f"${latex}$", buffer, prop=FontProperties(size=size), format="svg"
        )
    text = buffer.getvalue().decode("utf-8")
    width = float(re.search(r'width="([\d.]+)pt"', text).group(1))
    height = float(re.search(r'height="([\d.]+)pt"', text).group(1))
    encoded = base64.b64encode(text.encode("utf-8")).decode("ascii")
    return f"data:image/svg+xml;base64,{encoded}", width, height, float(depth or 0.0)


def _image(self, node, latex, display):
    latex = " ".join(latex.split())
    if display:  # fractions at full size in a displayed formula, as TeX sets them
        latex = re.sub(r"\\frac(?=\W)", r"\\dfrac", latex)
    try:
        source, width, height, depth = _svg(latex, display)
    except Exception as exc:  # a formula mathtext cannot read: say which, keep the text
        logger.warning(f"mathtext cannot draw {latex!r}: {exc}", location=node)
        return f'<code class="math">{html.escape(latex)}</code>'
    alt = html.escape(latex, quote=True)
    style = f"width:{width:.2f}pt;height:{height:.2f}pt"
    if not display:
        style += f";vertical-align:{-depth:.2f}pt"
    return f'<img class="math" src="{source}" alt="{alt}" style="{style}">'


def visit_inline(self, node):
    self.body.append(_image(self, node, node.astext(), display=False))
    raise nodes.SkipNode


def visit_block(self, node):
    from sphinx.util.math import get_node_equation_number

    latex = node.astext()
    equations = latex.split("\n\n") if node.get("nowrap") else [latex]
    self.body.append(self.starttag(node, "div", CLASS="math-display"))
    if node.get("number"):
        number = get_node_equation_number(self, node)
        self.body.append(f'<span class="eqno">({number})')
        self.add_permalink_ref(node, "Link to this equation")
        self.body.append("</span>")
    for latex in equations:
        self.body.append(f"<p>{_image(self, node, latex, display=True)}</p>")
    self.body.append("</div>")
    raise nodes.SkipNode


def setup(app):
    app.add_html_math_renderer(
        "mathtext_svg", inline_renderers=(visit_inline, None), block_renderers=(visit_block, None)
    )
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}
