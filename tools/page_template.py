"""
The templates of the generated pages: Markdown a writer edits, with fields.

A template (``tools/templates/NAME.md``) is the page's text with Python
format fields (``{name}``, ``{sd:.1f}``) where the generator puts its
figures and tables. After the body, ``<!-- snippet: NAME -->`` starts a
snippet: words the generator uses where its figures call for them (one of
two sentences, a paragraph per occasion). HTML comments elsewhere are
notes to the writer and are dropped.
"""

from pathlib import Path
import re

TEMPLATES = Path(__file__).with_name('templates')
SNIPPET = re.compile(r'^<!-- snippet: ([\w-]+) -->$', re.M)
COMMENT = re.compile(r'<!--(?! snippet:).*?-->\n?', re.S)


class Template:
    """A page's template: its body and its snippets."""

    def __init__(self, name):
        self.path = TEMPLATES / f'{name}.md'
        parts = SNIPPET.split(COMMENT.sub('', self.path.read_text()))
        self.body = parts[0]
        self.snippets = {k: v.strip() for k, v in zip(parts[1::2], parts[2::2])}

    def snippet(self, key, /, **fields):
        """Return the snippet ``key`` with its fields filled in."""
        return self._fill(self.snippets[key], fields, f'snippet {key}')

    def page(self, **fields):
        """Return the body with its fields filled in."""
        return self._fill(self.body, fields, 'body')

    def _fill(self, text, fields, what):
        try:
            filled = text.format_map(fields)
        except KeyError as exc:
            raise KeyError(f'{self.path} ({what}): no value for field {exc}') from None
        return re.sub(r'\n{3,}', '\n\n', filled)
