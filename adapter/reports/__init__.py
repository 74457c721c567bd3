"""The reports: charts and frames (matplotlib, pyvista) and the ParaView report
(``pvscripts/`` runs under pvbatch). They draw what they are given: they import no other
room."""
