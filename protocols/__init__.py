"""Protocol families, one module each: message kinds, behaviours, metrics, oracle checks."""
