"""The whole-system evaluation (`handover-eval`, docs/evaluation.md): a declared population of
receivers and objects (`population`), one whole stack per episode (`runner`), records read
from each episode's recording (`recording`, `record`), and a report with 95 % intervals
(`summary`, `stats`, `report`, `plots`). Offline: no service imports it."""
