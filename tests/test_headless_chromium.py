"""tests/headless_chromium.py: a wait outlasts a navigation that cuts off its evaluation."""

import pytest

from headless_chromium import HeadlessChromium, find_chromium


def test_a_wait_outlasts_the_navigation_that_cuts_off_its_evaluation(tmp_path):
    """A page that leaves for another after 200 ms, and a wait whose every evaluation takes
    400 ms (a promise): the first is cut off by the navigation ("Inspected target navigated or
    closed"), the wait goes on and finds the second page's flag (the library gallery's click on
    a material, which failed a run of the suite so)."""
    if find_chromium() is None:
        pytest.skip("no Chromium here: `make test` installs it")
    (tmp_path / "b.html").write_text("<script>window.arrived = true;</script>")
    (tmp_path / "a.html").write_text("<script>setTimeout(() => { location.href = 'b.html'; }, 200);</script>")
    late = "new Promise(r => setTimeout(() => r(window.arrived === true), 400))"
    with HeadlessChromium(tmp_path / "profile") as browser:
        browser.open((tmp_path / "a.html").as_uri())
        assert browser.wait_for(late, timeout=30) is True
        assert browser.evaluate("location.pathname").endswith("/b.html")
        browser.open((tmp_path / "a.html").as_uri())
        with pytest.raises(RuntimeError, match="navigated|destroyed|context"):    # one evaluation: cut off
            browser.evaluate(late)
