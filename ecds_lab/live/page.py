"""The live page: server-rendered PNGs and a JSON status polled once a second by a few lines of JS."""

from __future__ import annotations

import html

PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>ecds-lab live: {title}</title>
<link rel="icon" href="data:,">
<style>
body {{ font-family: sans-serif; margin: 1em 2em; max-width: 1300px; }}
.status {{ font-weight: bold; }} .completed {{ color: #070; }} .failed, .aborted, .interrupted {{ color: #b00; }}
progress {{ width: 30em; }} img {{ max-width: 100%; }} .plots {{ display: flex; flex-wrap: wrap; gap: 1em; }}
table {{ border-collapse: collapse; font-size: 90%; }} td {{ padding: 0 0.8em; border-bottom: 1px solid #ddd; }}
</style></head>
<body>
<h1>{title}</h1>
<p>status: <span id="status" class="status">…</span> · <span id="rows">0</span> rows of about
<span id="expected">?</span> · <span id="points">0</span> readings plotted · ETA <span id="eta">?</span></p>
<p><progress id="bar" max="1" value="0"></progress> <span id="error"></span></p>
<div class="plots"><img id="ls" alt="inductance against distance" src="ls.png">
<img id="temperatures" alt="temperatures and heater power" src="temperatures.png"></div>
<h2>latest readings</h2><table id="latest"></table>
<script>
function eta(s) {{ if (s === null) return "?"; s = Math.round(s);
  return Math.floor(s / 60) + " min " + (s % 60) + " s"; }}
// Each plot is asked for again when the run has grown, but only once its last picture has arrived: replacing an
// image still loading aborts its request, and on a busy machine every picture would be abandoned for the next.
const PLOTS = ["ls", "temperatures"], wanted = {{}}, loading = {{}};
function show(id) {{
  const img = document.getElementById(id);
  if (loading[id] || wanted[id] === undefined || img.dataset.shown === wanted[id]) return;
  loading[id] = true; img.dataset.shown = wanted[id]; img.src = wanted[id];
}}
for (const id of PLOTS) {{
  const img = document.getElementById(id);
  loading[id] = !img.complete;
  img.onload = img.onerror = () => {{ loading[id] = false; show(id); }};
}}
async function poll() {{
  try {{
    const s = await (await fetch("status.json", {{cache: "no-store"}})).json();
    const st = document.getElementById("status");
    st.textContent = s.status; st.className = "status " + s.status;
    for (const [id, v] of [["rows", s.rows], ["expected", s.expected_rows], ["points", s.plotted_points],
                           ["eta", eta(s.remaining_s)], ["error", s.error]])
      document.getElementById(id).textContent = v;
    document.getElementById("bar").value = s.fraction;
    document.getElementById("latest").innerHTML = Object.entries(s.latest).map(([k, v]) =>
      "<tr><td>" + k + "</td><td>" + (v === null ? "–" : Number(v).toPrecision(7)) + "</td></tr>").join("");
    for (const id of PLOTS) {{ wanted[id] = id + ".png?rows=" + s.rows; show(id); }}
  }} catch (e) {{ document.getElementById("error").textContent = "server gone: " + e; }}
  setTimeout(poll, 1000);
}}
poll();
</script></body></html>
"""


def page(title: str) -> str:
    return PAGE.format(title=html.escape(title))
