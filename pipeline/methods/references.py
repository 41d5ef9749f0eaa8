"""The original publications of the methods, cited to users in ``pipeline methods`` and the
reports (one place for each citation). Docstrings cite the seeds the formulas were taken
from (DESIGN.md "Seed numbers"); these are where the methods come from."""

REFERENCES: dict[str, str] = {
    "rake1980": "H. Rake, \"Step response and frequency response methods\", Automatica "
                "16(5):519-526, 1980",
    "seborg1989": "D. E. Seborg, T. F. Edgar, D. A. Mellichamp, Process Dynamics and "
                  "Control, Wiley, 1989",
    "busoniu": "L. Busoniu, System Identification, lecture \"Transient analysis\", "
               "Technical University of Cluj-Napoca (seed 001)",
    "strejc1959": "V. Strejc, \"Näherungsverfahren für aperiodische "
                  "Übergangscharakteristiken\", Regelungstechnik 7(7):124-128, 1959",
    "harriott1964": "P. Harriott, Process Control, McGraw-Hill, 1964",
    "smith1972": "C. L. Smith, Digital Computer Process Control, Intext, 1972",
    "sundaresan1978": "K. R. Sundaresan, P. R. Krishnaswamy, \"Estimation of time delay, "
                      "time constant parameters in time, frequency, and Laplace domains\", "
                      "Canadian Journal of Chemical Engineering 56(2):257-262, 1978",
    "viteckova2004": "M. Vítečková, in B. Šulc, M. Vítečková, Teorie a praxe návrhu "
                     "regulačních obvodů, ČVUT Praha, 2004",
    "latzel": "W. Latzel's time-percentage method, as given in B. Šulc, M. Vítečková, "
              "Teorie a praxe návrhu regulačních obvodů, ČVUT Praha, 2004",
    "jakoubek2009": "P. Jakoubek, \"Identifikace parametrů stabilních nekmitavých "
                    "soustav\", Automatizace 52(2), 2009 (seed 002, the comparison of "
                    "seven methods)",
    "astrom2006": "K. J. Åström, T. Hägglund, Advanced PID Control, ISA, 2006 (integrating "
                  "processes: the model K_v e^{-sL}/s from the slope and the intercept of "
                  "the step response's asymptote)",
    "balaguer2011": "P. Balaguer, V. Alfaro, O. Arrieta, \"Second order inverse response "
                    "process identification from transient step response data\", ISA "
                    "Transactions 50(2):231-238, 2011",
}
