"""
MkDocs hooks for the site (``hooks:`` in mkdocs.yml).

The package's docstrings name other objects with Sphinx roles
(``:class:`~.streams.agent_keys```), which mkdocstrings renders as they are;
a reader would see the raw markup. After each page is rendered the roles are
dropped and a reference is shown as the object's name (a leading ``~`` or
``.`` path shortened to its last part, as Sphinx shows it).
"""

import re

_ROLES = 'class|mod|func|meth|attr|data|exc|obj|const'
# in rendered HTML a role's backquoted target has become <code>...</code>
_HTML_ROLE = re.compile(r':(?:py:)?(?:' + _ROLES + r'):<code>([^<]*)</code>')


def _shown(target):
    """Return how a role's target reads: ``~a.b.c`` and ``.b.c`` as ``c``."""
    if target.startswith(('~', '.')):
        return target.lstrip('~.').rsplit('.', 1)[-1]
    return target


def strip_roles(html):
    """Return ``html`` with every Sphinx role replaced by its target in code."""
    return _HTML_ROLE.sub(lambda m: f'<code>{_shown(m.group(1))}</code>', html)


def on_page_content(html, page, config, files):
    """Drop Sphinx roles from a rendered page (mkdocstrings leaves them in)."""
    return strip_roles(html)


_WEB_SHIM = re.compile(r'<script src="https://unpkg\.com/iframe-worker/shim"></script>')


def worker_from_disk(html, depth):
    """Return ``html`` loading the site's own file:// worker instead of a shim from the web."""
    src = '../' * depth + 'javascripts/file_worker.js'
    return _WEB_SHIM.sub(f'<script src="{src}"></script>', html)


def on_post_page(output, page, config):
    """Search from disk without the web: the offline plugin's shim is the site's own."""
    return worker_from_disk(output, page.file.dest_uri.count('/'))
