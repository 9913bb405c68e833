"""A task and an agent written as a user would write them: one file each, plus one registration
call in that file (``tests/test_extension.py`` uses them)."""
