"""rosbook: the support library shared by the course book, its labs and its grader."""

from rosbook.session import Session, SimClock, ros

__all__ = ["Session", "SimClock", "ros"]
