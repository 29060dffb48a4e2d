"""A pot line of many pots: which pots deviate from the starting model, how, and whether alike.

- :mod:`.pots`: the line's pots and their records (simulated, each pot a cell of its own, or
  your files in the data contract);
- :mod:`.screen`: one pot screened with the starting model (its channel tests and, where one
  disagrees, every hypothesis' free delta scored: the cheap part of discovery, one job a pot);
- :mod:`.groups`: the line's table (pots x channels), the pots that one hypothesis explains as
  well as any grouped, and a group's pots pooled into one data set, on which discovery names one
  effect and fits one closed form;
- :mod:`.check`: the group's one correction checked on each of its pots alone.
"""
