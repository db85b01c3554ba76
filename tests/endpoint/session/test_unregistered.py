"""The rate limit of errors about messages on unregistered topics, on a clock of its own."""

from __future__ import annotations

from simbridge.endpoint.session.unregistered import MAX_REMEMBERED, UnregisteredReports


def test_one_report_per_topic_per_interval() -> None:
    reports = UnregisteredReports(interval=1.0, per_interval=10)
    assert reports.due("/a", 100.0) == ""
    assert reports.due("/a", 100.5) is None
    assert reports.due("/a", 101.0) == ""


def test_reports_past_the_cap_are_counted_into_the_next_one() -> None:
    reports = UnregisteredReports(interval=1.0, per_interval=2)
    assert reports.due("/a", 100.0) == ""
    assert reports.due("/b", 100.1) == ""
    assert reports.due("/c", 100.2) is None
    assert reports.due("/d", 100.3) is None
    assert reports.due("/e", 101.0) == " (2 more messages on unregistered topics were not reported)"
    assert reports.due("/f", 101.1) == ""


def test_a_registered_topic_is_reported_at_once_after_it_is_dropped() -> None:
    reports = UnregisteredReports(interval=1.0, per_interval=10)
    assert reports.due("/a", 100.0) == ""
    reports.forget("/a")
    assert reports.due("/a", 100.1) == ""


def test_topics_remembered_stay_bounded() -> None:
    reports = UnregisteredReports(interval=1.0, per_interval=10**6)
    for i in range(3 * MAX_REMEMBERED):
        reports.due(f"/junk{i}", 100.0)
        assert len(reports) <= MAX_REMEMBERED
