"""tests/headless_chromium.py: a wait outlasts a navigation that cuts off its evaluation."""

import pytest

from headless_chromium import HeadlessChromium, find_chromium

# on a.html: leave for b.html 50 ms into the evaluation, and answer only at 400 ms (cut off by then);
# on b.html: true at once
LEAVING = ("window.arrived === true || new Promise(r => { setTimeout(() => { location.href = 'b.html'; }, 50);"
           " setTimeout(() => r(false), 400); })")


def test_a_wait_outlasts_the_navigation_that_cuts_off_its_evaluation(tmp_path):
    """An evaluation that starts a navigation and answers after it: the navigation cuts it off
    ("Inspected target navigated or closed"); a wait goes on and finds the next page's flag (the
    library gallery's click on a material, which failed a run of the suite so)."""
    if find_chromium() is None:
        pytest.skip("no Chromium here: `make test` installs it")
    (tmp_path / "a.html").write_text("<p>a</p>")
    (tmp_path / "b.html").write_text("<script>window.arrived = true;</script>")
    with HeadlessChromium(tmp_path / "profile") as browser:
        browser.open((tmp_path / "a.html").as_uri())
        browser.wait_for("document.readyState === 'complete'")
        with pytest.raises(RuntimeError, match="navigated|destroyed|context"):    # one evaluation: cut off
            browser.evaluate(LEAVING)
        browser.open((tmp_path / "a.html").as_uri())
        browser.wait_for("document.readyState === 'complete' && location.pathname.endsWith('/a.html')")
        assert browser.wait_for(LEAVING, timeout=30) is True
        assert browser.evaluate("location.pathname").endswith("/b.html")
