"""A pot line of many pots: which pots deviate from the starting model, how, and whether alike.

- :mod:`.pots`: the line's pots and their records (simulated, each pot a cell of its own, or
  your files in the data contract);
- :mod:`.screen`: one pot screened with the starting model (its filter's channel tests: the
  cheap part of discovery, one job a pot);
- :mod:`.groups`: the line's table (pots x channels), the pots that disagree alike grouped (the
  same channels flagged, the same sign of their innovations' bias), and a group's pots pooled
  into one data set, on which one round of discovery names one effect and one closed form.
"""
