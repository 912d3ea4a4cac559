"""The applications: analyses, simulation, controllers, optimal control and
the chapter's studies, on the numeric back-end and the generated functions."""
