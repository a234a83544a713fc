"""The names ``fit`` takes by keyword -- losses and optimizers -- without importing
JAX or nlopt: the command line builds its options (and ``--help``) from these."""

HYBRID = "hybrid"     # M1 + an image term: fitting.objective, fitting.image_error
LOSSES = ("log", "ngan", "relative", "cuberoot", HYBRID)

#: nlopt's algorithms by the name ``--optimizer`` takes (fitting.optimizers reads the codes)
NLOPT_CODES = {"lbfgs": "LD_LBFGS", "bobyqa": "LN_BOBYQA", "crs2": "GN_CRS2_LM", "mlsl": "G_MLSL_LDS"}
OPTX_SOLVERS = ("optx_bfgs", "optx_lm", "optx_dogleg")
OPTIMIZERS = tuple(NLOPT_CODES) + OPTX_SOLVERS
DEFAULT_OPTIMIZER = "lbfgs"
