/*---------------------------------------------------------------------------*\
    whaleFrameAcceleration: the whale frame's acceleration as a uniform body
    force on the fluid (see the header).
\*---------------------------------------------------------------------------*/

#include "whaleFrameAccelerationSource.H"
#include "whaleFrame.H"
#include "fvMatrices.H"
#include "addToRunTimeSelectionTable.H"

// * * * * * * * * * * * * * Static Member Functions * * * * * * * * * * * * //

namespace Foam
{
namespace fv
{
defineTypeNameAndDebug(whaleFrameAccelerationSource, 0);
addToRunTimeSelectionTable(option, whaleFrameAccelerationSource, dictionary);
} // End namespace fv
} // End namespace Foam


namespace
{

//- The frame's acceleration on the mesh (m/s2), zero before the first
//  exchange
Foam::dimensionedVector frameAcceleration(const Foam::fvMesh& mesh)
{
    const Foam::uniformDimensionedVectorField* a =
        Foam::whaleFrame::acceleration(mesh);
    if (a)
    {
        return *a;
    }
    return Foam::dimensionedVector(
        Foam::whaleFrame::accelerationName,
        Foam::dimAcceleration,
        Foam::Zero
    );
}

} // End anonymous namespace


// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::fv::whaleFrameAccelerationSource::whaleFrameAccelerationSource(
    const word& sourceName,
    const word& modelType,
    const dictionary& dict,
    const fvMesh& mesh
) :
    option(sourceName, modelType, dict, mesh)
{
    read(dict);
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

void Foam::fv::whaleFrameAccelerationSource::addSup(
    fvMatrix<vector>& eqn,
    const label fieldi
)
{
    eqn += frameAcceleration(mesh_);
}


void Foam::fv::whaleFrameAccelerationSource::addSup(
    const volScalarField& rho,
    fvMatrix<vector>& eqn,
    const label fieldi
)
{
    eqn += rho * frameAcceleration(mesh_);
}


bool Foam::fv::whaleFrameAccelerationSource::read(const dictionary& dict)
{
    if (!option::read(dict))
    {
        return false;
    }
    fieldNames_ = coeffs_.getOrDefault<wordList>("fields", wordList{"U"});
    applied_.setSize(fieldNames_.size(), false);
    return true;
}


// ************************************************************************* //
