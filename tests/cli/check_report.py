#!/usr/bin/python3
"""cli.report.html: OUT/report.html (apps/paper_report.py) opened in headless Chromium.

    check_report.py OUT PNG [--ensemble]

Checks: the page refers to nothing outside itself (every src/href is a data: URI or an
in-page anchor, no <script>, no <link>); Chromium's DOM (--dump-dom) has the findings table
(id findings) with twelve rows numbered 1 to 12, each with a verdict holds / does not hold /
cannot be decided, the SFF table with a row per partition (6), and ten figures whose images
decoded (naturalWidth is not in the dumped DOM, so the figures' PNG data is decoded with
matplotlib instead); a screenshot (--screenshot) is written to PNG and is not blank.
With --ensemble (the page of an ensemble's output, apps/paper_report.py write_ensemble): the
verdicts are holds / does not hold / undecided at this ensemble size, the page also has the
ensemble's table (id ensemble) and the list of criteria (id criteria), and its figures are
fig02b, fig03-fig12 and ensemble_trends (12; 11 without OUT/consolidations.csv).
Chromium missing: skipped (77), except under CI (CI=true), where it is a failure
(scripts/run.sh test installs it).
"""
import base64
import html.parser
import io
import os
import re
import shutil
import subprocess
import sys
import tempfile

VERDICTS = {"holds", "does not hold", "cannot be decided"}
ENSEMBLE_VERDICTS = {"holds", "does not hold", "undecided at this ensemble size"}


def fail(msg):
    print(f"check_report: FAIL: {msg}")
    sys.exit(1)


class Dom(html.parser.HTMLParser):
    """Collects the findings rows (cell texts), the tables and the images of a page."""

    def __init__(self):
        super().__init__()
        self.tables, self.images, self.refs, self.tags, self.ids = [], [], [], set(), set()
        self.table = None
        self.row = None
        self.cell = None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self.tags.add(tag)
        if "id" in a:
            self.ids.add(a["id"])
        for k in ("src", "href"):
            if k in a:
                self.refs.append(a[k])
        if tag == "table":
            self.table = {"id": a.get("id"), "rows": [], "head": True}
            self.tables.append(self.table)
        elif tag == "tbody" and self.table is not None:
            self.table["head"] = False
        elif tag == "tr" and self.table is not None and not self.table["head"]:
            self.row = []
            self.table["rows"].append(self.row)
        elif tag == "td" and self.row is not None:
            self.cell = []
        elif tag == "img":
            self.images.append(a.get("src", ""))

    def handle_endtag(self, tag):
        if tag == "td" and self.cell is not None:
            self.row.append("".join(self.cell).strip())
            self.cell = None
        elif tag == "tr":
            self.row = None
        elif tag == "table":
            self.table = None

    def handle_data(self, data):
        if self.cell is not None:
            self.cell.append(data)


def chromium():
    for name in ("chromium", "chromium-browser"):
        if shutil.which(name):
            return name
    return None


def main():
    out, png = sys.argv[1], os.path.abspath(sys.argv[2])
    ensemble = "--ensemble" in sys.argv[3:]
    verdict_set = ENSEMBLE_VERDICTS if ensemble else VERDICTS
    figures = (11 + os.path.exists(os.path.join(out, "consolidations.csv"))) if ensemble else 10
    page = os.path.abspath(os.path.join(out, "report.html"))
    if not os.path.isfile(page):
        fail(f"{page} missing")
    exe = chromium()
    if exe is None:
        if os.environ.get("CI") == "true":
            fail("chromium not found under CI (scripts/run.sh test installs it)")
        print("check_report: skipped: chromium not found (apt-get install chromium)")
        sys.exit(77)
    src = Dom()
    with open(page, encoding="utf-8") as fh:
        src.feed(fh.read())
    outside = [r for r in src.refs if not (r.startswith("data:") or r.startswith("#"))]
    if outside or "script" in src.tags or "link" in src.tags:
        fail(f"the page refers to outside resources: {outside[:3]}, script: {'script' in src.tags}")

    with tempfile.TemporaryDirectory() as profile:
        base = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
                f"--user-data-dir={profile}", "--hide-scrollbars"]
        r = subprocess.run(base + ["--dump-dom", "file://" + page], capture_output=True, text=True, timeout=120)
        if r.returncode != 0 or "<table" not in r.stdout:
            fail(f"chromium --dump-dom failed (exit {r.returncode}): {r.stderr[-500:]}")
        if os.path.exists(png):
            os.remove(png)
        s = subprocess.run(base + ["--window-size=1280,2400", f"--screenshot={png}", "file://" + page],
                           capture_output=True, text=True, timeout=120)
        if s.returncode != 0 or not os.path.isfile(png):
            fail(f"chromium --screenshot failed (exit {s.returncode}): {s.stderr[-500:]}")

    dom = Dom()
    dom.feed(r.stdout)
    tables = {t["id"]: t for t in dom.tables}
    if "findings" not in tables:
        fail(f"no table#findings in the rendered DOM (tables: {[t['id'] for t in dom.tables]})")
    rows = tables["findings"]["rows"]
    if len(rows) != 12:
        fail(f"the findings table has {len(rows)} rows, not 12")
    for k, row in enumerate(rows, start=1):
        if len(row) != 5 or row[0] != str(k) or row[2] not in verdict_set or not re.search(r"[0-9]", row[3]):
            fail(f"findings row {k}: {row[:4]}")
    if ensemble and not {"ensemble", "criteria"} <= dom.ids:
        fail(f"no table#ensemble or ol#criteria in the rendered DOM (ids: {sorted(dom.ids)})")
    sff = [t for t in dom.tables if t["rows"] and t["rows"][0][0] == "{all}"]
    if not sff or len(sff[0]["rows"]) != 6:
        fail("no SFF table with the 6 partitions")
    import matplotlib.image as mpimg
    import numpy as np
    if len(dom.images) != figures:
        fail(f"{len(dom.images)} figures in the page, expected {figures}")
    for i, u in enumerate(dom.images):
        if not u.startswith("data:image/png;base64,"):
            fail(f"figure {i}: not an embedded PNG")
        img = mpimg.imread(io.BytesIO(base64.b64decode(u.split(",", 1)[1])), format="png")
        if img.shape[0] < 200 or img.shape[1] < 400:
            fail(f"figure {i}: {img.shape}")
    shot = mpimg.imread(png)[:, :, :3]
    differ = np.count_nonzero(np.abs(shot - shot[0, 0]).sum(axis=2) > 0.1) / (shot.shape[0] * shot.shape[1])
    if shot.shape[1] != 1280 or differ < 0.02:
        fail(f"{png}: {shot.shape}, {differ:.1%} of the pixels differ from the background")
    verdicts = [row[2] for row in rows]
    undecided = sum(v not in ("holds", "does not hold") for v in verdicts)
    print(f"check_report: rendered by {exe}; {'an ensemble; ' if ensemble else ''}findings table: 12 rows "
          f"({verdicts.count('holds')} hold, {verdicts.count('does not hold')} do not, {undecided} undecided); "
          f"SFF table 6 partitions; {figures} embedded figures; screenshot {png} ({shot.shape[1]}x{shot.shape[0]}, "
          f"{differ:.0%} non-background pixels)")


if __name__ == "__main__":
    main()
