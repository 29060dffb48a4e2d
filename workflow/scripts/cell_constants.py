"""Write the cell's constants (derived from physics.cell) as a table, and log them."""

from costa import runtime
from costa.physics import constants_table

log = runtime.configure(snakemake)
table = constants_table(snakemake.params.physics)
table.to_csv(snakemake.output.table, index=False)
log.info("the cell's constants:\n%s", table.to_string(index=False))
