"""A Griffe extension (mkdocs.yml, mkdocstrings' ``extensions``): Sphinx roles in docstrings become links.

The docstrings are numpydoc, read by ``help()`` as well as by the site, so they
name other objects the Sphinx way, ``:func:`synthesize``` or
``:class:`~warp_texton.FilterOptions```. mkdocstrings renders Markdown, so
this turns each role into an autorefs cross-reference: a bare name is a public
name of ``warp_texton`` when the package exports it, else a name of the
docstring's own module. A reference to an object that the site does not
document fails ``mkdocs build --strict``; references to modules (``:mod:``)
and to a module's own helpers (a bare name that the package does not export)
link when the site documents them and stay plain text otherwise.
"""

from __future__ import annotations

import re

import griffe

ROLE = re.compile(r":(?:py:)?(func|class|meth|attr|data|obj|exc|mod|const):`(~?)([\w.]+)(?:\(\))?`")


class SphinxRoles(griffe.Extension):
    def __init__(self, package: str = "warp_texton"):
        self.package = package

    def on_package(self, *, pkg, **kwargs) -> None:
        public = set(pkg.members)
        for obj in _walk(pkg):
            if obj.docstring is not None:
                module = obj.module.path if hasattr(obj, "module") else pkg.path
                obj.docstring.value = ROLE.sub(lambda m: self._link(m, public, module), obj.docstring.value)

    def _link(self, m: re.Match, public: set, module: str) -> str:
        role, short, name = m.groups()
        title = f"`{name.rsplit('.', 1)[-1] if short else name}`"
        optional = role == "mod"
        if name.startswith(self.package):
            target = name
        elif name.split(".", 1)[0] in public:
            target = f"{self.package}.{name}"
        else:  # a helper of the docstring's module: linked if the site documents it
            target, optional = f"{module}.{name}", True
        if optional:
            return f'<autoref identifier="{target}" optional><code>{title.strip("`")}</code></autoref>'
        return f"[{title}][{target}]"


def _walk(obj):
    yield obj
    for member in obj.members.values():
        if not member.is_alias and member.parent is obj:
            yield from _walk(member)
