/*---------------------------------------------------------------------------*\
  =========                 |
  \\      /  F ield         | OpenFOAM: The Open Source CFD Toolbox
   \\    /   O peration     |
    \\  /    A nd           | www.openfoam.com
     \\/     M anipulation  |
-------------------------------------------------------------------------------
    Formula as in OpenFOAM's functionObjects::forces (forces.C),
    Copyright (C) 2011-2016 OpenFOAM Foundation,
    Copyright (C) 2015-2020 OpenCFD Ltd., GPL-3.0-or-later.
\*---------------------------------------------------------------------------*/

#include "patchLoads.H"
#include "turbulentTransportModel.H"

// * * * * * * * * * * * * * * * Static Data Members * * * * * * * * * * * * //

const Foam::scalar Foam::patchLoads::defaultRhoInf = 1025;

// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::patchLoads::patchLoads(
    const fvMesh& mesh,
    const scalar rhoInf,
    const word& pName
) :
    mesh_(mesh),
    rhoInf_(rhoInf),
    pPtr_(mesh.findObject<volScalarField>(pName)),
    tdevReff_()
{
    typedef incompressible::turbulenceModel icoTurbModel;

    const icoTurbModel* turbPtr =
        mesh.findObject<icoTurbModel>(icoTurbModel::propertiesName);

    if (turbPtr)
    {
        tdevReff_ = turbPtr->devReff();
    }
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

Foam::tmp<Foam::vectorField> Foam::patchLoads::pressure(const label patchi
) const
{
    const volScalarField& p = *pPtr_;

    // As forces::rho(p): p in Pa needs no density
    const scalar rho = (p.dimensions() == dimPressure) ? 1 : rhoInf_;

    return rho * mesh_.Sf().boundaryField()[patchi] * p.boundaryField()[patchi];
}


Foam::tmp<Foam::vectorField> Foam::patchLoads::viscous(const label patchi) const
{
    return rhoInf_
        * (mesh_.Sf().boundaryField()[patchi]
           & tdevReff_().boundaryField()[patchi]);
}


// ************************************************************************* //
