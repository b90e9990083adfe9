"""The perception study: stimuli, rendering, trial design, harness, analysis."""
