"""Every FMU's documentation/index.html, rendered in headless Chromium (Debian's
``chromium``) from the FMU's own files, offline: the MathML is laid out (every <math> has a
non-zero box, every dotted letter's <mover> stands taller than its letter: the dot is drawn
above it), every image loads (an <img> with a natural width), every solver of the
modelDescription's `solver` enumeration is named, the sections are there, the page holds no
script.  The measurements come from a copy of the page with a measuring script appended
(the page itself has none), read back with ``--dump-dom``.  A screenshot of each page goes
to ``$MBFMU_SCREENSHOT_DIR`` (default ``target/screenshots``): the CI artifact.
"""

from __future__ import annotations

import json
import os
import pathlib
import re
import shutil
import subprocess
import unicodedata
import zipfile

import pytest
from fmpy import read_model_description

import fmu_support as fs

FMUS = sorted(p.stem for p in fs.fmu_dir().glob("*.fmu"))
# Written as a Lagrangian (`export_fmu!(lagrangian …)`): the page also shows T and V typeset
# from the traced code.
LAGRANGIANS = {"CompoundPendulum", "DoublePendulum", "SliderCrank", "SliderCrankSurplus",
               "SpringRodPendulum", "NonlinearBicycle", "RotatingHoopBead", "PulledPendulum"}

MEASURE = """
<script>
window.addEventListener('load', () => {
  const box = e => e.getBoundingClientRect();
  const maths = [...document.querySelectorAll('math')];
  const movers = [...document.querySelectorAll('mover')];
  const r = {
    maths: maths.length,
    empty_maths: maths.filter(m => box(m).width <= 0 || box(m).height <= 0).length,
    movers: movers.length,
    flat_movers: movers.filter(m => !(box(m).height > box(m.firstElementChild).height + 0.5)).length,
    dotted: movers.map(m => { const b = box(m); return [b.left, b.top, b.right, b.bottom]; }),
    images: [...document.images].map(i => [i.getAttribute('src'), i.complete && i.naturalWidth > 0]),
    text: document.body.innerText,
    ids: [...document.querySelectorAll('[id]')].map(e => e.id),
  };
  const pre = document.createElement('pre');
  pre.id = 'mbfmu-measure';
  pre.textContent = JSON.stringify(r);
  document.body.appendChild(pre);
});
</script>
"""


def chromium() -> str:
    path = shutil.which("chromium") or shutil.which("chromium-browser")
    if path is None:
        pytest.fail("chromium is not installed (apt-get install chromium)", pytrace=False)
    return path


def run_chromium(tmp, *args) -> str:
    profile = tmp / "profile"
    cmd = [chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
           "--no-first-run", "--disable-background-networking", "--disable-component-update",
           "--disable-sync", f"--user-data-dir={profile}", *args]
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    return out.stdout


def screenshot_dir() -> pathlib.Path:
    env = os.environ.get("MBFMU_SCREENSHOT_DIR")
    return pathlib.Path(env) if env else fs.REPO / "target" / "screenshots"


@pytest.mark.parametrize("name", FMUS)
def test_the_page_renders_offline_with_its_mathematics_plots_and_solvers(name, tmp_path):
    path = fs.fmu_file(name)
    with zipfile.ZipFile(path) as z:
        z.extractall(tmp_path / "fmu")
    page = tmp_path / "fmu" / "documentation" / "index.html"
    html = page.read_text(encoding="utf-8")
    assert "<script" not in html.lower()
    assert not re.search(r"(src|href)=\"(https?:)?//", html), "the page loads nothing from the network"
    measured = page.with_name("measured.html")
    measured.write_text(html.replace("</body>", MEASURE + "</body>"), encoding="utf-8")
    dom = run_chromium(tmp_path, "--virtual-time-budget=10000", WINDOW, "--hide-scrollbars",
                       "--dump-dom", measured.as_uri())
    m = re.search(r'<pre id="mbfmu-measure">(.*?)</pre>', dom, re.S)
    assert m, "the measuring script did not run"
    r = json.loads(m.group(1).replace("&lt;", "<").replace("&gt;", ">").replace("&amp;", "&"))

    assert r["maths"] > 0 and r["empty_maths"] == 0, r
    # Every dot over a letter in the equations is typeset (a <mover>), none left to a font.
    equations = re.search(r'<ul class="eq">(.*?)</ul>', html, re.S).group(1)
    raw = [c for c in equations if {"\u0307", "\u0308"} & set(unicodedata.normalize("NFD", c))]
    assert not raw, f"dots left as characters in the equations: {raw}"
    if "<mover" in equations:
        assert r["movers"] > 0 and r["flat_movers"] == 0, r
    if name in LAGRANGIANS:
        traced = html[html.index('id="traced"'):]
        traced = traced[:traced.index("</ul>")]
        # T and V each typeset, or said to be too long (more than 60 leaves: the bicycle's,
        # the spring-rod pendulum's); the pendulums' short enough to read.
        assert traced.count("<math>") + traced.count("too long to typeset") == 2, traced
        if name in {"CompoundPendulum", "DoublePendulum", "RotatingHoopBead", "PulledPendulum"}:
            assert traced.count("<math>") == 2, traced
    assert r["images"], "no scene plot"
    assert all(ok for _, ok in r["images"]), [src for src, ok in r["images"] if not ok]
    md = read_model_description(str(path))
    solver = next(v for v in md.modelVariables if v.name == "solver")
    names = [item.name for item in solver.declaredType.items]
    assert len(names) >= 12
    for method in names:
        assert method in r["text"], f"solver {method} not named"
    for section in ("equations", "variables", "scenes", "linearisation", "solvers", "reference"):
        assert section in r["ids"]

    shots = screenshot_dir()
    shots.mkdir(parents=True, exist_ok=True)
    shot = shots / f"{name}.png"
    run_chromium(tmp_path, f"--screenshot={shot}", WINDOW, "--hide-scrollbars", page.as_uri())
    assert shot.stat().st_size > 10_000
    assert_dots_stand_above_their_letters(shot, r["dotted"])


# The measuring run and the screenshot lay the page out in the same window.
WINDOW = "--window-size=1000,1400"

TYPESET = """
<script>
window.addEventListener('load', () => {
  const box = e => { const b = e.getBoundingClientRect(); return [b.left, b.top, b.right, b.bottom]; };
  const eq = document.querySelector('ul.eq');
  const r = {
    tokens: [...eq.querySelectorAll('mi, mtext')].map(e => e.textContent),
    roots: [...eq.querySelectorAll('msqrt')].map(root => ({
      text: root.textContent,
      box: box(root),
      scripts: [...root.querySelectorAll('msubsup, msup')].map(s => ({
        tag: s.localName,
        parts: [...s.children].map(c => c.textContent),
        sup: box(s.lastElementChild),
      })),
    })),
    ranges: [...document.querySelector('#variables ~ table').rows]
      .map(tr => [...tr.cells].map(c => c.innerText)),
  };
  const pre = document.createElement('pre');
  pre.id = 'mbfmu-typeset';
  pre.textContent = JSON.stringify(r);
  document.body.appendChild(pre);
});
</script>
"""


def test_the_bicycle_page_typesets_names_roots_and_numbers_as_written(tmp_path):
    """NonlinearBicycle's page, laid out by Chromium: `f (WhippleBicycle)` keeps the name as
    one token (not W with the subscript "hippleBicycle"); in the contact constraint
    `√(1 − a_z²)` the square is a_z's (one <msubsup> of a, z and 2) and is drawn inside the
    root; the ranges read `1e-12`, not `0.000000000001`."""
    with zipfile.ZipFile(fs.fmu_file("NonlinearBicycle")) as z:
        z.extractall(tmp_path / "fmu")
    page = tmp_path / "fmu" / "documentation" / "index.html"
    html = page.read_text(encoding="utf-8")
    measured = page.with_name("typeset.html")
    measured.write_text(html.replace("</body>", TYPESET + "</body>"), encoding="utf-8")
    dom = run_chromium(tmp_path, "--virtual-time-budget=10000", WINDOW, "--hide-scrollbars",
                       "--dump-dom", measured.as_uri())
    m = re.search(r'<pre id="mbfmu-typeset">(.*?)</pre>', dom, re.S)
    assert m, "the measuring script did not run"
    r = json.loads(m.group(1).replace("&lt;", "<").replace("&gt;", ">").replace("&amp;", "&"))

    assert "WhippleBicycle" in r["tokens"], r["tokens"]
    assert not [t for t in r["tokens"] if "hippleBicycle" in t and t != "WhippleBicycle"]

    [contact] = [root for root in r["roots"] if "az2" in root["text"]]
    squares = [s for s in contact["scripts"]
               if s["tag"] == "msubsup" and s["parts"] == ["a", "z", "2"]]
    assert len(squares) == 1, f"a_z² is not one <msubsup> of a, z and 2: {contact}"
    [square] = squares
    left, top, right, bottom = contact["box"]
    s_left, s_top, s_right, s_bottom = square["sup"]
    assert left <= s_left and s_right <= right + 0.5 and top - 0.5 <= s_top, (contact, square)

    header, *rows = r["ranges"]
    column = header.index("range")
    ranges = [row[column] for row in rows if row[column]]
    assert "[1e-12, ∞]" in ranges, ranges
    assert not [x for x in ranges if "0.000000000001" in x or "e9" in x], ranges


def assert_dots_stand_above_their_letters(shot: pathlib.Path, dotted) -> None:
    """In the screenshot, each dotted letter (a <mover>'s box, those inside the picture) shows
    its dot: the ink of the box, row by row, is two runs at least, the dot's above the
    letter's with a blank row between. A laid-out box is not enough: with
    `<mover accent="true">` Chromium put the dot onto the letter's top stroke with DejaVu
    Math TeX Gyre (the fallback math font on Debian), where it could not be seen."""
    from PIL import Image

    gray = Image.open(shot).convert("L")
    w, h = gray.size
    seen = 0
    for left, top, right, bottom in dotted:
        if bottom > h or right > w:
            continue
        seen += 1
        box = (int(left), int(top), int(right + 0.999), int(bottom + 0.999))
        region = gray.crop(box)
        rows = [min(region.crop((0, y, region.width, y + 1)).getdata()) < 128
                for y in range(region.height)]
        runs = sum(1 for y, ink in enumerate(rows) if ink and (y == 0 or not rows[y - 1]))
        assert runs >= 2, f"the dot over the letter at {box} is not drawn apart from it"
    assert seen > 0 or not dotted, "no dotted letter inside the screenshot"
