"""Checks shared by the page tests: a page is self-contained (no script, no external reference, every image an
embedded PNG)."""

from __future__ import annotations

import base64
import re
from html.parser import HTMLParser


class _Refs(HTMLParser):
    """Every URL-bearing attribute of a page, and whether it has script or style-sheet links."""

    def __init__(self):
        super().__init__()
        self.urls, self.tags = [], []

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        for name, value in attrs:
            if name in ("src", "href", "srcset", "poster", "data", "action", "background"):
                self.urls.append(value or "")


def _refs(text: str) -> _Refs:
    p = _Refs()
    p.feed(text)
    return p


def assert_self_contained(text: str) -> list[str]:
    """No script, no external reference, every image an embedded PNG; returns the image payloads (base64)."""
    refs = _refs(text)
    assert "script" not in refs.tags and "link" not in refs.tags and "iframe" not in refs.tags
    assert refs.urls and all(u.startswith("data:image/png;base64,") for u in refs.urls), refs.urls[:3]
    assert not re.search(r"https?://|url\(|@import", text)
    payloads = [u.split(",", 1)[1] for u in refs.urls]
    for b64 in payloads:
        assert base64.b64decode(b64)[:8] == b"\x89PNG\r\n\x1a\n"
    return payloads
