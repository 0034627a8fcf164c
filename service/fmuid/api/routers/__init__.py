"""One router per resource: jobs, their reports, and the service's health."""
