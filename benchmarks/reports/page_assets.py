"""The style sheet and the script every results page inlines (written here, no library).

The script does three things, each on the elements the page marks for it:

- ``table.sortable``: a click on a header sorts the rows by that column, numbers as numbers
  (``0.93 [0.90, 0.96]`` sorts by 0.93), a second click reverses;
- ``.cmp``: the image comparison. Two choices (A and B) among the preview tiles; a slider shows A
  left of it and B right of it, the flip button (or the ``f`` key over the image) shows one whole
  and then the other; a lens follows the cursor with the visible image four times larger. A
  choice ``src|tile|tiles|ref`` with ``ref >= 0`` is an error map: the tile and the reference
  tile of the same strip blended with CSS ``difference``, brightened by
  :data:`~benchmarks.reports.previews.ERROR_GAIN`;
- SVG charts need nothing: each point carries a ``<title>`` that the browser shows on hover;
  nor does the decision's heatmap (:mod:`benchmarks.reports.heatmap`): its colours are inline
  and each cell's ``title`` is its hover text.

Not for: anything that reads image pixels (pages opened from disk may not).
"""

from benchmarks.reports.previews import ERROR_GAIN

__all__ = ["SCRIPT", "STYLE"]

STYLE = """
body{font:14px/1.45 system-ui,sans-serif;margin:1.5em auto;max-width:1200px;padding:0 1em;
color:#222}
h1{font-size:1.6em}h2{border-bottom:1px solid #ccc;margin-top:2em}h3,h4{margin-top:1.4em}
table{border-collapse:collapse;margin:.6em 0;font-size:12px;display:block;overflow-x:auto;
max-width:100%}
td,th{border:1px solid #ddd;padding:2px 6px;text-align:right;white-space:nowrap}
th{background:#f3f3f3;cursor:pointer;position:sticky;top:0}
th.asc::after{content:" \\25B2"}th.desc::after{content:" \\25BC"}
td:first-child,th:first-child{text-align:left}
details{margin:.5em 0}summary{cursor:pointer;font-weight:600}
.charts img{max-width:100%;display:block;margin:.5em 0}
.svgs{display:flex;flex-wrap:wrap;gap:12px}
.svgs figure{margin:0}.svgs figcaption{font-size:12px;text-align:center}
.legend span{display:inline-block;margin-right:12px;font-size:12px}
.legend i{display:inline-block;width:12px;height:12px;margin-right:4px;vertical-align:-1px}
.cmp{display:flex;gap:16px;align-items:flex-start;flex-wrap:wrap;margin:.5em 0}
.cmp-controls{display:flex;flex-direction:column;gap:6px;min-width:260px}
.cmp-view{position:relative;width:384px;height:384px;cursor:crosshair;border:1px solid #999}
.cmp-layer{position:absolute;inset:0;background-repeat:no-repeat;image-rendering:pixelated}
.cmp-lens{position:absolute;width:128px;height:128px;border:2px solid #fff;
box-shadow:0 0 0 1px #000;pointer-events:none;display:none;background-repeat:no-repeat;
image-rendering:pixelated}
.cmp-label{position:absolute;bottom:4px;background:#000a;color:#fff;font-size:11px;
padding:1px 4px}
.cmp-label.a{left:4px}.cmp-label.b{right:4px}
.anims img{margin:4px;border:1px solid #ccc}
.hm{margin:.8em 0}.hm figcaption{font-weight:600;margin-bottom:.3em}
table.heatmap td.hm-cell{text-align:center;font-size:11px;line-height:1.25;min-width:84px;
cursor:help}
table.heatmap th{cursor:default;text-align:left}
.hm-legend{position:relative;width:360px;margin:.3em 12px 1.6em}
.hm-bar{height:12px;border:1px solid #999}
.hm-ticks{position:relative;height:14px;font-size:11px}
.hm-ticks span{position:absolute;transform:translateX(-50%)}
.hm-legend small{display:block;width:min(720px,90vw)}
"""

SCRIPT = r"""
(function(){
function key(text){
 var m=text.replace(/[*\u2191\u2193]/g,'').trim().match(/^-?\d+(\.\d+)?(e-?\d+)?/i);
 return m?parseFloat(m[0]):null;}
document.querySelectorAll('table.sortable').forEach(function(table){
 table.querySelectorAll('th').forEach(function(th,col){
  th.addEventListener('click',function(){
   var asc=!th.classList.contains('asc');
   table.querySelectorAll('th').forEach(function(h){h.classList.remove('asc','desc');});
   th.classList.add(asc?'asc':'desc');
   var body=table.tBodies[0],rows=Array.prototype.slice.call(body.rows);
   rows.sort(function(r,s){var a=r.cells[col]?r.cells[col].textContent:'',
    b=s.cells[col]?s.cells[col].textContent:'',x=key(a),y=key(b),c;
    if(x!==null&&y!==null){c=x-y;}else if(x!==null){c=-1;}else if(y!==null){c=1;}
    else{c=a.localeCompare(b);}
    return asc?c:-c;});
   rows.forEach(function(r){body.appendChild(r);});
  });
 });
});
function tile(layer,value,size,z,dx,dy){
 var p=value.split('|'),n=+p[2],err=+p[3]>=0,url='url("'+p[0]+'")';
 z=z||1;dx=dx||0;dy=dy||0;
 function at(i){return(-i*size*z+dx)+'px '+dy+'px';}
 layer.style.backgroundImage=err?url+','+url:url;
 layer.style.backgroundSize=(n*size*z)+'px '+(size*z)+'px';
 layer.style.backgroundPosition=err?at(+p[1])+','+at(+p[3]):at(+p[1]);
 layer.style.backgroundBlendMode=err?'difference':'normal';
 layer.style.filter=err?'brightness(GAIN)':'none';}
document.querySelectorAll('.cmp').forEach(function(cmp){
 var view=cmp.querySelector('.cmp-view'),a=cmp.querySelector('.cmp-layer.a'),
  b=cmp.querySelector('.cmp-layer.b'),lens=cmp.querySelector('.cmp-lens'),
  sa=cmp.querySelector('select.a'),sb=cmp.querySelector('select.b'),
  slider=cmp.querySelector('input[type=range]'),la=cmp.querySelector('.cmp-label.a'),
  lb=cmp.querySelector('.cmp-label.b'),size=view.clientWidth,mode='slider';
 function show(){tile(a,sa.value,size);tile(b,sb.value,size);
  la.textContent='A: '+sa.options[sa.selectedIndex].text;
  lb.textContent='B: '+sb.options[sb.selectedIndex].text;
  if(mode==='slider'){b.style.display='';b.style.clipPath='inset(0 0 0 '+slider.value+'%)';}
  else if(mode==='b'){b.style.display='';b.style.clipPath='none';}
  else{b.style.display='none';}
  cmp.dataset.shown=mode;}
 function flip(){mode=(mode==='a')?'b':'a';show();}
 sa.addEventListener('change',show);sb.addEventListener('change',show);
 slider.addEventListener('input',function(){mode='slider';show();});
 cmp.querySelector('button.flip').addEventListener('click',flip);
 view.tabIndex=0;
 view.addEventListener('keydown',function(e){if(e.key==='f'){flip();}});
 view.addEventListener('mousemove',function(e){
  var r=view.getBoundingClientRect(),x=e.clientX-r.left,y=e.clientY-r.top,z=4,
   src=(mode==='a'||(mode==='slider'&&x<r.width*slider.value/100))?sa.value:sb.value,
   w=lens.offsetWidth/2;
  lens.style.display='block';lens.style.left=(x-w)+'px';lens.style.top=(y-w)+'px';
  tile(lens,src,size,z,-x*z+w,-y*z+w);});
 view.addEventListener('mouseleave',function(){lens.style.display='none';});
 show();
});
})();
""".replace("GAIN", str(ERROR_GAIN))
