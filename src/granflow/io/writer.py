"""placeholder"""


def write_rheocompass(*a, **k):
    raise NotImplementedError


def write_trios(*a, **k):
    raise NotImplementedError
