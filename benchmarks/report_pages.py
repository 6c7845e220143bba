"""Printed pages of a report: ``python benchmarks/report_pages.py REPORT.html [...]``.

Prints each report to PDF with headless Chromium (A4 by the report's own print CSS, default
margins, no header or footer) and counts its pages; writes ``benchmarks/report_pages.json``.
Needs a Chromium on the PATH (Debian: ``apt-get install chromium``); without one it says so and
exits 2. The docs' page counts (docs/guide/report.md) come from this command on the tanker's
``flexlift run`` folder.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent


def pages(report: Path, browser: str) -> int:
    """The number of A4 pages ``report`` prints to."""
    with tempfile.TemporaryDirectory() as tmp:
        pdf = Path(tmp) / "report.pdf"
        subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu",
                        "--no-pdf-header-footer", f"--print-to-pdf={pdf}",
                        report.resolve().as_uri()], check=True, timeout=300,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        return len(re.findall(rb"/Type\s*/Page[^s]", pdf.read_bytes()))


def main(argv: list[str]) -> int:
    browser = next((b for b in ("chromium", "chromium-browser", "google-chrome")
                    if shutil.which(b)), None)
    if browser is None:
        print("report_pages: no Chromium on the PATH (apt-get install chromium)", file=sys.stderr)
        return 2
    counts = {str(p): pages(Path(p), browser) for p in argv}
    for p, n in counts.items():
        print(f"{n:4d} pages  {p}")
    (HERE / "report_pages.json").write_text(json.dumps(counts, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
