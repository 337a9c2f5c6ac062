"""The documentation site builds without a warning and works in a browser.

Builds ``docs/`` with ``sphinx-build -W --keep-going`` into a temporary folder, serves it on
127.0.0.1 and opens it in headless Chromium: the index, an API page and a task page render
their headings, every image on them loads, and the search page finds "DiscFlow" (results
rendered by Sphinx's own JavaScript). Skipped when Sphinx (the ``docs`` extra) or
``/usr/bin/chromium`` is missing, unless the environment variable CI is set: there they
must be installed, and the test fails instead.
"""

from __future__ import annotations

import functools
import html
import http.server
import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
import threading
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CHROMIUM = "/usr/bin/chromium"


def _need(ok: bool, reason: str) -> None:
    if ok:
        return
    if os.environ.get("CI"):
        pytest.fail(f"{reason} (CI is set: the docs extra and chromium must be installed)")
    pytest.skip(reason)


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The built site's folder."""
    _need(all(importlib.util.find_spec(m) for m in ("sphinx", "furo", "myst_parser")),
          "sphinx, furo or myst-parser not installed: pip install -e '.[docs]'")
    out = tmp_path_factory.mktemp("site")
    # an empty numba cache: a kernel compiled while autodoc imports discgym would land there
    cache = out / "numba_cache"
    cache.mkdir()
    res = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
         "-d", str(out / ".doctrees"), str(ROOT / "docs"), str(out / "html")],
        capture_output=True, text=True, timeout=600,
        env={**os.environ, "NUMBA_CACHE_DIR": str(cache)})
    assert res.returncode == 0, f"sphinx-build -W failed:\n{res.stderr[-6000:]}"
    compiled = [p.name for p in cache.rglob("*") if p.is_file()]
    assert not compiled, f"building the docs compiled numba kernels: {compiled[:5]}"
    return out / "html"


def test_site_has_its_pages(site):
    for page in ("index.html", "quickstart.html", "scenes.html", "api/simulation.html",
                 "search.html", "searchindex.js", "_images/DiscFlow-v0.gif",
                 *(f"tasks/{t}.html" for t in ("DiscReactor-v0", "DiscKinetics-v0",
                                               "DiscEconomic-v0", "DiscJacket-v0",
                                               "DiscFlow-v0"))):
        assert (site / page).is_file(), page
    # repository files outside docs/ are linked on the repository, not left dangling
    assert "https://github.com/discgym/discgym/blob/main/" in (site / "api" /
                                                               "simulation.html").read_text()


#: Loads each page into an iframe (same origin), waits for it (and, on the search page,
#: for the results), and writes what it found as JSON into <pre id="result">.
HARNESS = """<!doctype html><html><head><meta charset="utf-8"></head><body>
<pre id="result">pending</pre>
<iframe id="f" width="1200" height="900"></iframe>
<script>
const pages = %s;
const frame = document.getElementById("f");
const sleep = ms => new Promise(r => setTimeout(r, ms));
async function visit(url) {
  await new Promise(resolve => { frame.onload = resolve; frame.src = url; });
  const doc = frame.contentDocument;
  if (url.includes("search.html")) {
    for (let k = 0; k < 100 && !doc.querySelector(".search-summary"); k++) await sleep(100);
    await sleep(1500);  // (results are appended one by one)
  }
  // (a heading's text without its permalink sign)
  const text = sel => [...doc.querySelectorAll(sel)].map(
    e => e.textContent.replace(/\\u00b6/g, "").trim());
  return {
    url: url, title: doc.title, h1: text("h1"), h2: text("h2"),
    ids: [...doc.querySelectorAll("dt[id]")].map(e => e.id),
    images: [...doc.querySelectorAll("img")].map(
      i => ({src: i.getAttribute("src"), ok: i.complete && i.naturalWidth > 0})),
    summary: text(".search-summary").join(" "),
    results: [...doc.querySelectorAll("#search-results li a")].map(a => a.textContent.trim()),
  };
}
(async () => {
  const out = [];
  for (const p of pages) out.push(await visit(p));
  document.getElementById("result").textContent = JSON.stringify(out);
})();
</script></body></html>
"""

PAGES = ["index.html", "api/simulation.html", "tasks/DiscFlow-v0.html",
         "search.html?q=DiscFlow"]


@pytest.fixture(scope="module")
def browsed(site, tmp_path_factory):
    """What headless Chromium saw of :data:`PAGES`, served from ``site`` on 127.0.0.1."""
    _need(Path(CHROMIUM).exists(), f"{CHROMIUM} not installed: apt-get install chromium")
    (site / "_harness.html").write_text(HARNESS % json.dumps(PAGES))
    handler = functools.partial(_QuietHandler, directory=str(site))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    profile = tmp_path_factory.mktemp("chromium")
    try:
        res = subprocess.run(
            [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu",
             "--disable-background-networking", "--disable-component-update", "--disable-sync",
             "--no-first-run", f"--user-data-dir={profile}", "--virtual-time-budget=30000",
             "--dump-dom", f"http://127.0.0.1:{server.server_address[1]}/_harness.html"],
            capture_output=True, text=True, timeout=120)
    finally:
        server.shutdown()
        server.server_close()
        thread.join(5)
        shutil.rmtree(profile, ignore_errors=True)
    m = re.search(r'<pre id="result">(.*?)</pre>', res.stdout, re.S)
    assert m and m.group(1) != "pending", f"the harness did not finish:\n{res.stderr[-3000:]}"
    return {p["url"]: p for p in json.loads(html.unescape(m.group(1)))}


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):  # (no request log on the test's stderr)
        pass


def test_pages_render_their_headings(browsed):
    index = browsed["index.html"]
    assert index["h1"][:1] == ["discgym"], index
    api = browsed["api/simulation.html"]
    assert any(h.startswith("Simulation") for h in api["h1"]), api["h1"]
    assert "discgym.Simulation" in api["ids"] and "discgym.Simulation.step" in api["ids"]
    task = browsed["tasks/DiscFlow-v0.html"]
    assert task["h1"][0].startswith("DiscFlow-v0"), task["h1"]
    for section in ("Description", "Action Space", "Observation Space", "Rewards",
                    "Arguments", "Version History"):
        assert any(h.startswith(section) for h in task["h2"]), (section, task["h2"])


def test_images_load(browsed):
    for url, page in browsed.items():
        broken = [i["src"] for i in page["images"] if not i["ok"]]
        assert not broken, f"{url}: images that did not load: {broken}"
    task = browsed["tasks/DiscFlow-v0.html"]["images"]
    assert any(i["src"].endswith("DiscFlow-v0.gif") for i in task), task
    assert browsed["index.html"]["images"], "the index shows the flagship episode"


def test_search_finds_discflow(browsed):
    search = browsed["search.html?q=DiscFlow"]
    assert "Search finished" in search["summary"], search
    assert any("DiscFlow-v0" in r for r in search["results"]), search["results"]
