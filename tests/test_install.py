"""Install hints give the command that works where plotgate runs (issue 37): from the
clone of an editable install, by name from an index otherwise."""

import json
import sys
from importlib import metadata

from plotgate import install


def test_an_editable_install_is_told_to_install_from_its_clone(monkeypatch):
    direct = {"dir_info": {"editable": True}, "url": "file:///home/me/plot%20gate"}
    _installed_as(monkeypatch, json.dumps(direct))
    hint = install.install_hint("view")
    assert hint == f'{sys.executable} -m pip install -e "/home/me/plot gate[view]"'


def test_an_index_install_is_told_the_extra_by_name(monkeypatch):
    _installed_as(monkeypatch, None)
    assert install.install_hint("plot") == f'{sys.executable} -m pip install "plotgate[plot]"'
    wheel = {"archive_info": {}, "url": "file:///tmp/plotgate-0.2.0-py3-none-any.whl"}
    _installed_as(monkeypatch, json.dumps(wheel))
    assert install.install_hint("plot").endswith(' install "plotgate[plot]"')


def _installed_as(monkeypatch, direct_url: str | None) -> None:
    class Distribution:
        def read_text(self, name):
            assert name == "direct_url.json"
            return direct_url

    monkeypatch.setattr(metadata, "distribution", lambda name: Distribution())
