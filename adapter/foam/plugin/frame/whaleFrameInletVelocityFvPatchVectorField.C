/*---------------------------------------------------------------------------*\
    whaleFrameInletVelocity: the inlet velocity of a flow in the whale's
    frame, the step-server's frame velocity (see the header).
\*---------------------------------------------------------------------------*/

#include "whaleFrameInletVelocityFvPatchVectorField.H"
#include "whaleFrame.H"
#include "addToRunTimeSelectionTable.H"
#include "volFields.H"

// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::whaleFrameInletVelocityFvPatchVectorField::
    whaleFrameInletVelocityFvPatchVectorField(
        const fvPatch& p,
        const DimensionedField<vector, volMesh>& iF
    ) :
    fixedValueFvPatchVectorField(p, iF)
{}


Foam::whaleFrameInletVelocityFvPatchVectorField::
    whaleFrameInletVelocityFvPatchVectorField(
        const fvPatch& p,
        const DimensionedField<vector, volMesh>& iF,
        const dictionary& dict
    ) :
    fixedValueFvPatchVectorField(p, iF, dict)
{}


Foam::whaleFrameInletVelocityFvPatchVectorField::
    whaleFrameInletVelocityFvPatchVectorField(
        const whaleFrameInletVelocityFvPatchVectorField& ptf,
        const fvPatch& p,
        const DimensionedField<vector, volMesh>& iF,
        const fvPatchFieldMapper& mapper
    ) :
    fixedValueFvPatchVectorField(ptf, p, iF, mapper)
{}


Foam::whaleFrameInletVelocityFvPatchVectorField::
    whaleFrameInletVelocityFvPatchVectorField(
        const whaleFrameInletVelocityFvPatchVectorField& ptf
    ) :
    fixedValueFvPatchVectorField(ptf)
{}


Foam::whaleFrameInletVelocityFvPatchVectorField::
    whaleFrameInletVelocityFvPatchVectorField(
        const whaleFrameInletVelocityFvPatchVectorField& ptf,
        const DimensionedField<vector, volMesh>& iF
    ) :
    fixedValueFvPatchVectorField(ptf, iF)
{}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

void Foam::whaleFrameInletVelocityFvPatchVectorField::updateCoeffs()
{
    if (updated())
    {
        return;
    }
    const uniformDimensionedVectorField* u =
        whaleFrame::velocity(this->patch().boundaryMesh().mesh());
    if (u)
    {
        fvPatchVectorField::operator==(u->value());
    }
    fixedValueFvPatchVectorField::updateCoeffs();
}


void Foam::whaleFrameInletVelocityFvPatchVectorField::write(Ostream& os) const
{
    fvPatchVectorField::write(os);
    writeEntry("value", os);
}


// * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * //

namespace Foam
{
makePatchTypeField(
    fvPatchVectorField,
    whaleFrameInletVelocityFvPatchVectorField
);
}

// ************************************************************************* //
