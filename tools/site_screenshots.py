"""
Screenshots of the built site as a reader sees it from disk (headless Chromium).

``make site-screenshots`` builds the site and runs this: each page named
below is opened as a ``file://`` URL at 1280 x 1000 px and written to
``site_screenshots/<page>.png``, to look at (a directory listing, raw
markup or a table cut off show at once).

    python tools/site_screenshots.py [--site site] [--out site_screenshots]
"""

import argparse
from pathlib import Path
import subprocess
import sys

from site_check import find_chromium

PAGES = ('index', 'tutorials/python', 'tutorials/node', 'tutorials/sumo', 'tutorials/calibrate',
         'presets', 'faults', 'gross-failures', 'bags', 'robot-localization', 'glossary',
         'node', 'calibrating', 'sumo', 'profiles', 'reference/api',
         'reference/commands', 'reference/commands-simulate', 'walks', 'architecture',
         'performance', 'generalisation', 'calibration', 'close-the-loop', 'decisions/index',
         'decisions/0034-faults-on-demand', 'decisions/0035-a-few-public-names')


def main(argv=None):
    """Write one PNG per page; exit 2 without Chromium."""
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--site', type=Path, default=Path('site'))
    ap.add_argument('--out', type=Path, default=Path('site_screenshots'))
    ap.add_argument('--width', type=int, default=1280)
    args = ap.parse_args(argv)
    browser = find_chromium('site_screenshots')
    if browser is None:
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    for page in PAGES:
        html = (args.site / f'{page}.html').resolve()
        if not html.is_file():
            print(f'site_screenshots: {html} not built', file=sys.stderr)
            return 2
        png = (args.out / f'{page.replace("/", "_")}.png').resolve()
        subprocess.run([browser, '--headless', '--no-sandbox', '--disable-gpu',
                        '--hide-scrollbars', f'--window-size={args.width},1000',
                        f'--screenshot={png}', html.as_uri()],
                       check=True, capture_output=True, timeout=120)
        print(f'wrote {png}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
