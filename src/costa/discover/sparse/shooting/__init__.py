"""The shooting route: closed forms fitted by multiple shooting, for a pot line's hourly and 8-hourly samples.

The record cut into hourly segments fitted by Levenberg-Marquardt with the closed form's
coefficients (:mod:`.fit`), every hypothesis' closed form screened at once, linearised at the
uncorrected model's fit (:mod:`.screen`), the best fitted and ranked to decide the first round
(:mod:`.round`).
"""
