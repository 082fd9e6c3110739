"""Model families: each module declares one family (``FAMILY``) that the generic layers use.

A family names its result types, the manifest ``test`` kind of its records, and (as dotted
paths, loaded when used) the callables that analyse a campaign's records and render their
report section.
"""
