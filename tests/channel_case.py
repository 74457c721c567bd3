"""The tiny 2D channel with a square hole that tests/test_loads.py and tests/test_motion.py
build with blockMesh: the vertex numbering, the FoamFile header, the laminar flow dictionaries
and the initial U and p, with the square's wall named by the test."""

#: a dictionary file's header
HEADER = "FoamFile {{ version 2.0; format ascii; class {cls}; object {obj}; }}\n"


def vertex(i: int, j: int, k: int) -> int:
    """The blockMesh vertex label of the 4 x 4 x 2 grid of block corners."""
    return k * 16 + j * 4 + i


def side_quad(a: tuple, b: tuple) -> str:
    """The side face of the z-extruded edge from block corner (i, j) ``a`` to ``b``."""
    return f"({vertex(*a, 0)} {vertex(*b, 0)} {vertex(*b, 1)} {vertex(*a, 1)})"


FV_SCHEMES = """
ddtSchemes { default Euler; } gradSchemes { default Gauss linear; }
divSchemes { default none; div(phi,U) Gauss linearUpwind grad(U);
             div((nuEff*dev2(T(grad(U))))) Gauss linear; }
laplacianSchemes { default Gauss linear corrected; } interpolationSchemes { default linear; }
snGradSchemes { default corrected; }
"""


def fv_solution(tolerance: float, rel_tol: float) -> str:
    return f"""
solvers
{{
    "(p|pcorr)" {{ solver PCG; preconditioner DIC; tolerance {tolerance}; relTol {rel_tol}; }}
    "(p|pcorr)Final" {{ $p; relTol 0; }}
    "(U|UFinal)" {{ solver smoothSolver; smoother symGaussSeidel; tolerance {tolerance};
                   relTol 0; }}
}}
PIMPLE {{ correctPhi yes; nOuterCorrectors 1; nCorrectors 2; nNonOrthogonalCorrectors 0; }}
"""


def flow_files(body: str) -> dict:
    """constant/ and 0/ files for laminar flow past the square whose wall patch is ``body``:
    ``{relative path: (class, text)}``."""
    return {
        "constant/transportProperties": ("dictionary", "transportModel Newtonian; nu 0.01;\n"),
        "constant/turbulenceProperties": ("dictionary", "simulationType laminar;\n"),
        "0/U": ("volVectorField", f"""
dimensions [0 1 -1 0 0 0 0]; internalField uniform (1 0 0);
boundaryField
{{
    inlet {{ type fixedValue; value uniform (1 0 0); }}
    outlet {{ type inletOutlet; inletValue uniform (0 0 0); value uniform (1 0 0); }}
    walls {{ type slip; }}
    {body} {{ type movingWallVelocity; value uniform (0 0 0); }}
    frontAndBack {{ type empty; }}
}}
"""),
        "0/p": ("volScalarField", f"""
dimensions [0 2 -2 0 0 0 0]; internalField uniform 0;
boundaryField
{{
    inlet {{ type zeroGradient; }} outlet {{ type fixedValue; value uniform 0; }}
    walls {{ type zeroGradient; }} {body} {{ type zeroGradient; }} frontAndBack {{ type empty; }}
}}
"""),
    }


def write_files(case, files: dict) -> None:
    """Write ``{relative path: (class, text)}`` with their headers."""
    for rel, (cls, body) in files.items():
        path = case / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(HEADER.format(cls=cls, obj=path.name) + body)
